"""The byte-bounded LRU cache, and single-flight over HTTP: N identical plans, one analysis."""

from __future__ import annotations

import asyncio
import threading
from typing import Any

import anyio
import httpx
import numpy as np
import pytest
from fastapi import FastAPI

from service.work import engine as engine_module
from service.work.cache import ByteLRU

pytestmark = pytest.mark.anyio


def block(n: int) -> np.ndarray:
    return np.zeros(n, dtype=np.uint8)


async def test_lru_evicts_the_least_recently_used_within_the_byte_bound() -> None:
    cache = ByteLRU(max_bytes=100)

    async def get(key: str, size: int = 40) -> bool:
        async def compute() -> np.ndarray:
            return block(size)

        return (await cache.get_or_compute(key, compute))[1]

    assert [await get("a"), await get("b"), await get("a")] == [False, False, True]
    await get("c")  # 120 bytes: "b" is the least recently used
    assert (cache.bytes, len(cache), cache.evictions) == (80, 2, 1)
    assert await get("a") is True
    assert await get("b") is False
    assert await get("big", 101) is False  # larger than the whole cache: served, not kept
    assert cache.bytes <= 100
    assert await get("big", 101) is False


async def test_concurrent_misses_compute_once_and_errors_are_not_kept() -> None:
    cache = ByteLRU(max_bytes=1000)
    computed = 0
    release = asyncio.Event()

    async def compute() -> np.ndarray:
        nonlocal computed
        computed += 1
        await release.wait()
        return block(10)

    tasks = [asyncio.ensure_future(cache.get_or_compute("k", compute)) for _ in range(5)]
    await asyncio.sleep(0)
    release.set()
    results = await asyncio.gather(*tasks)
    assert computed == 1
    assert sorted(hit for _, hit in results) == [False, True, True, True, True]
    assert all(value is results[0][0] for value, _ in results)

    async def fail() -> np.ndarray:
        raise ValueError("boom")

    with pytest.raises(ValueError, match="boom"):
        await cache.get_or_compute("bad", fail)
    value, hit = await cache.get_or_compute("bad", compute)
    assert (hit, value.nbytes) == (False, 10)


async def test_a_caller_giving_up_does_not_cancel_the_others() -> None:
    cache = ByteLRU(max_bytes=1000)
    release = asyncio.Event()

    async def compute() -> np.ndarray:
        await release.wait()
        return block(10)

    first = asyncio.ensure_future(cache.get_or_compute("k", compute))
    second = asyncio.ensure_future(cache.get_or_compute("k", compute))
    await asyncio.sleep(0)
    first.cancel()
    release.set()
    value, hit = await second
    assert (value.nbytes, hit) == (10, True)
    assert len(cache) == 1


async def test_identical_concurrent_plans_analyse_once(
    app: FastAPI, client: httpx.AsyncClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = []
    release = threading.Event()
    analyse = engine_module._analyse

    def counting(*args: Any) -> Any:
        calls.append(args)
        release.wait(timeout=60)  # holds the analysis until every request waits for it
        return analyse(*args)

    monkeypatch.setattr(engine_module, "_analyse", counting)
    grid = np.zeros((40, 40), dtype=np.uint8)
    grid[10:30, 20] = 1
    r = await client.post("/maps", json={"grid": grid.tolist()})
    body = {"map_id": r.json()["map_id"], "start": [0, 0], "goal": [39, 39]}
    cache = app.state.engine.cache
    hits = cache.hits
    n = 8
    tasks = [asyncio.ensure_future(client.post("/plan", json=body)) for _ in range(n)]
    with anyio.fail_after(60):
        while cache.hits - hits < n - 1:
            await asyncio.sleep(0.01)
    release.set()
    answers = await asyncio.gather(*tasks)
    assert [a.status_code for a in answers] == [201] * n
    assert len(calls) == 1
    flags = sorted(a.json()["analysis"]["cache_hit"] for a in answers)
    assert flags == [False] + [True] * (n - 1)
    assert len({a.json()["plan_id"] for a in answers}) == n


async def test_an_on_evict_that_raises_leaves_the_cache_whole_and_no_waiter_hangs(
    caplog: pytest.LogCaptureFixture,
) -> None:
    told: list[Any] = []

    def on_evict(key: Any, value: Any) -> None:
        told.append(key)
        raise KeyError(key)  # as Engine._forget once did, deleting a plan twice

    cache = ByteLRU(max_bytes=100, on_evict=on_evict)
    for key in ("a", "b"):
        cache.get_or_compute_sync(key, lambda: block(40))
    release = asyncio.Event()

    async def compute() -> np.ndarray:
        await release.wait()
        return block(70)  # evicts "a" and "b"

    waiters = [asyncio.ensure_future(cache.get_or_compute("c", compute)) for _ in range(4)]
    await asyncio.sleep(0)
    release.set()
    with anyio.fail_after(10):
        results = await asyncio.gather(*waiters)
    assert sorted(hit for _, hit in results) == [False, True, True, True]
    assert (told, cache.bytes, len(cache), cache.evictions) == (["a", "b"], 70, 1, 2)
    assert "on_evict failed" in caplog.text
    cache.recharge("c", results[0][0])  # the cache still works
    assert cache.peek("c") is results[0][0]


def test_on_evict_may_use_the_cache_from_every_path() -> None:
    """``on_evict`` runs with the cache's lock released: on insert, on a value grown in place
    and on :meth:`ByteLRU.discard`, reading the cache from it does not deadlock."""
    cache = ByteLRU(max_bytes=100)
    seen: list[tuple[Any, Any]] = []
    cache.on_evict = lambda key, value: seen.append((key, cache.peek(key)))
    grows = block(10)

    def run() -> None:
        cache.get_or_compute_sync("a", lambda: grows)
        cache.get_or_compute_sync("b", lambda: block(50))
        cache.peek("a")
        grows.resize(60, refcheck=False)
        cache.recharge("a", grows)  # grown: evicts "b"
        cache.get_or_compute_sync("c", lambda: block(50))  # inserted: evicts "a"
        cache.discard("c")

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(timeout=10)
    assert not thread.is_alive(), "deadlocked: on_evict called holding the cache's lock"
    assert seen == [("b", None), ("a", None), ("c", None)]
    assert (cache.bytes, len(cache), cache.evictions) == (0, 0, 3)
