"""The HTTP service of ``shared/API.md`` over the planner: ``uvicorn service.main:app``."""

from service.config import Settings
from service.main import create_app

__all__ = ["Settings", "create_app"]
