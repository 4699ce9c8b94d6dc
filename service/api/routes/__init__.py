"""Every router of the API, gathered."""

from fastapi import APIRouter

from service.api.routes import health, maps, metrics, plans, simulate, viewer, zones

__all__ = ["routers"]

routers: tuple[APIRouter, ...] = tuple(
    module.router for module in (plans, maps, zones, simulate, viewer, health, metrics)
)
"""Every router, in the order their routes are matched: plans first (a step is the hot
request). The app includes each directly: a router nested in another costs a level of
matching on every request."""
