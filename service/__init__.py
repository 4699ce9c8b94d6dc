"""The HTTP service of the planner: ``uvicorn service.main:app`` serves it.

Importing ``service`` builds nothing: the app is made in ``service.main``, its settings live in
``service.config`` and its stores in ``service.stores``, each importable on its own.
"""

__all__: list[str] = []
