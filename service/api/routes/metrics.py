"""``/metrics``: the service's Prometheus metrics (``service.ops.metrics``)."""

from __future__ import annotations

from fastapi import APIRouter, Request, Response
from prometheus_client import CONTENT_TYPE_LATEST

from service.ops.metrics import Metrics

__all__ = ["router"]

router = APIRouter(tags=["service"])


@router.get(
    "/metrics",
    summary="Prometheus metrics",
    response_class=Response,
    responses={200: {"content": {"text/plain": {}}, "description": "Prometheus text format."}},
)
async def metrics(request: Request) -> Response:
    """Requests by route template and status (`planner_http_requests_total`, and their
    durations in `planner_http_request_duration_seconds`), the worker pool
    (`planner_pool_busy_workers`, `planner_pool_queue_depth`), the analysis cache
    (`planner_cache_hits_total`, `planner_cache_misses_total`, `planner_cache_bytes`), and the
    store's `planner_maps` and live `planner_plans`. Answers while the pool is busy."""
    registry: Metrics = request.app.state.metrics
    return Response(await registry.render(), media_type=CONTENT_TYPE_LATEST)
