"""The HTTP service of the planner: ``uvicorn service.main:app`` serves it; importing
``service`` builds nothing (the app is made in ``service.main``)."""

__all__: list[str] = []
