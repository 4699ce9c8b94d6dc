"""The HTTP layer: dependencies and thin routers."""

from service.api.routes import api_router

__all__ = ["api_router"]
