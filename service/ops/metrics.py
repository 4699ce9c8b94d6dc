"""Prometheus metrics of one app: requests by route template and status, the worker pool, the
analysis cache, and the maps and plans in the store. ``GET /metrics`` serves them."""

from __future__ import annotations

import contextlib
from bisect import bisect_left
from collections.abc import Iterator
from typing import TYPE_CHECKING

from prometheus_client import CollectorRegistry, generate_latest
from prometheus_client.core import (
    CounterMetricFamily,
    GaugeMetricFamily,
    HistogramMetricFamily,
    Metric,
)
from prometheus_client.registry import Collector
from prometheus_client.utils import floatToGoString

from service.errors import StoreUnavailable

if TYPE_CHECKING:
    from service.work.engine import Engine

__all__ = ["BUCKETS", "UNMATCHED", "Metrics"]

BUCKETS = (0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60)
"""Seconds: a step takes microseconds to milliseconds, a big map's analysis seconds."""
UNMATCHED = "unmatched"
"""The route label of a path no route matches: unknown paths never become label values."""


class Metrics:
    """The registry of one app; the lifespan hands it the engine (``metrics.engine = ...``).

    Requests are tallied in plain counts per (method, route, status), a few list updates a
    request on the event loop (a ``prometheus_client`` ``Counter`` and ``Histogram`` cost a
    step ~10 us more, in locks and bucket loops), and exposed at each scrape as the
    ``planner_http_requests`` counter and the ``planner_http_request_duration_seconds``
    histogram (:class:`_RequestCollector`)."""

    def __init__(self) -> None:
        self.registry = CollectorRegistry()
        # Per (method, route, status): the count in each bucket of BUCKETS (the last: over
        # them all), then the sum of the seconds.
        self.requests: dict[tuple[str, str, str], list[float]] = {}
        self.engine: Engine | None = None
        self.store_counts: tuple[int, int] | None = None
        """(maps, plans) as the store answered at the last scrape; None when it did not."""
        self.registry.register(_RequestCollector(self))
        self.registry.register(_EngineCollector(self))

    def observe(self, method: str, route: str, status: int, seconds: float) -> None:
        """Count one answered request (on the event loop: no other thread writes here)."""
        labels = (method, route, str(status))
        tally = self.requests.get(labels)
        if tally is None:
            tally = self.requests[labels] = [0.0] * (len(BUCKETS) + 2)
        tally[bisect_left(BUCKETS, seconds)] += 1
        tally[-1] += seconds

    async def render(self) -> bytes:
        """The metrics in Prometheus' text format, the store's counts read now."""
        self.store_counts = None
        if self.engine is not None:
            # planner_store_up says when the store does not answer; the rest still does.
            with contextlib.suppress(StoreUnavailable):
                self.store_counts = await self.engine.store.counts()
        return generate_latest(self.registry)


_BOUNDS = [*map(floatToGoString, BUCKETS), "+Inf"]
"""The buckets' ``le`` labels, written as ``prometheus_client.Histogram`` writes them."""


class _RequestCollector(Collector):
    """The requests' tallies as a counter and a histogram (buckets ``le`` each bound, as
    ``prometheus_client.Histogram`` exposes them: cumulative, then ``+Inf``)."""

    def __init__(self, metrics: Metrics) -> None:
        self._metrics = metrics

    def collect(self) -> Iterator[Metric]:
        labels = ["method", "route", "status"]
        requests = CounterMetricFamily(
            "planner_http_requests",
            "HTTP requests answered, by method, route template and status code.",
            labels=labels,
        )
        duration = HistogramMetricFamily(
            "planner_http_request_duration_seconds",
            "Time from a request's arrival to the end of its answer, in seconds.",
            labels=labels,
        )
        for key, tally in list(self._metrics.requests.items()):
            counts, total = tally[:-1], tally[-1]
            cumulative, buckets = 0.0, []
            for bound, count in zip(_BOUNDS, counts, strict=True):
                cumulative += count
                buckets.append((bound, cumulative))
            requests.add_metric(list(key), cumulative)
            duration.add_metric(list(key), buckets, total)
        yield requests
        yield duration


class _EngineCollector(Collector):
    """The pool's, the cache's and the store's figures, read when scraped."""

    def __init__(self, metrics: Metrics) -> None:
        self._metrics = metrics

    def collect(self) -> Iterator[Metric]:
        engine = self._metrics.engine
        if engine is None:
            return
        pool, cache, counts = engine.pool, engine.cache, self._metrics.store_counts
        gauges: list[tuple[str, str, float]] = [
            ("planner_pool_workers", "Worker threads.", pool.size),
            ("planner_pool_busy_workers", "Workers running a planner call now.", pool.busy),
            ("planner_pool_queue_depth", "Planner calls waiting for a worker.", pool.queued),
            ("planner_pool_warm", "1 once the kernels are compiled.", int(pool.warm)),
            ("planner_cache_bytes", "Bytes held by the analysis cache.", cache.bytes),
            ("planner_cache_max_bytes", "The cache's bound, PLANNER_CACHE_BYTES.", cache.max_bytes),
            ("planner_cache_entries", "Entries in the cache.", len(cache)),
            ("planner_store_up", "1 when the store answered this scrape.", counts is not None),
        ]
        if counts is not None:
            gauges.append(("planner_maps", "Maps in the store.", counts[0]))
            gauges.append(("planner_plans", "Live plans in the store.", counts[1]))
        for name, text, value in gauges:
            yield GaugeMetricFamily(name, text, value=float(value))
        counters: list[tuple[str, str, int]] = [
            ("planner_cache_hits", "Cache lookups that found their entry.", cache.hits),
            ("planner_cache_misses", "Cache entries computed.", cache.misses),
            ("planner_cache_evictions", "Cache entries dropped for room.", cache.evictions),
        ]
        for name, text, count in counters:
            yield CounterMetricFamily(name, text, value=count)
