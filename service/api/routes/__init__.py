"""Every router of the API, gathered."""

from fastapi import APIRouter

from service.api.routes import (
    fleets,
    health,
    live,
    mapf,
    maps,
    metrics,
    plans,
    simulate,
    viewer,
    zones,
)

__all__ = ["routers"]

routers: tuple[APIRouter, ...] = tuple(
    module.router
    for module in (plans, maps, zones, live, fleets, mapf, simulate, viewer, health, metrics)
)
"""Every router, in the order their routes are matched: plans first. The app includes each
directly (a router nested in another costs a level of matching on every request); the step, the
hot request, is a route of the app itself, matched before them
(:func:`service.api.routes.plans.add_step_route`)."""
