"""Every router of the API, gathered."""

from fastapi import APIRouter

from service.api.routes import health, maps, plans, simulate

__all__ = ["api_router"]

api_router = APIRouter()
for module in (maps, plans, simulate, health):
    api_router.include_router(module.router)
