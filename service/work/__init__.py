"""The planner's work in the service: the engine (plans built from cached analyses), the
byte-bounded cache and the worker pools."""

__all__: list[str] = []
