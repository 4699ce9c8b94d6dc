"""The planner's work in the service: the engine (plans built from cached analyses), the
byte-bounded cache, the worker pools and their size."""

__all__: list[str] = []
