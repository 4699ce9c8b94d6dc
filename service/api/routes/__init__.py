"""Every router of the API, gathered."""

from fastapi import APIRouter

from service.api.routes import health, maps, metrics, plans, simulate, viewer

__all__ = ["api_router"]

api_router = APIRouter()
# Plans first: a step is the hot request, and routes are matched in order.
for module in (plans, maps, simulate, viewer, health, metrics):
    api_router.include_router(module.router)
