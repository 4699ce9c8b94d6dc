"""The HTTP layer: dependencies and thin routers."""

from service.api.routes import routers

__all__ = ["routers"]
