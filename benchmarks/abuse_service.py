"""What the abuse benchmark measures with: the service under test (``python -m service`` with
two API keys, so two tenants), the ``/healthz`` and RSS watch, and the other tenant's small
requests, each in a process of its own so that the attacker's work does not slow them."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from multiprocessing import Event, Process, Queue
from multiprocessing.synchronize import Event as EventType
from pathlib import Path

import httpx
import numpy as np
from common import ROOT, free_port

ATTACKER, OTHER = "attacker-key", "other-key"
"""The two API keys: the tenant running the pattern, and the one that must not wait for it."""


def rss_mb(pid: int) -> float:
    status = Path(f"/proc/{pid}/status").read_text()
    return int(status.split("VmRSS:")[1].split()[0]) / 1024


def cpu_model() -> str:
    out = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
    facts = dict(line.split(":", 1) for line in out.splitlines() if ":" in line)
    return f"{facts.get('Model name', '?').strip()}, {facts.get('CPU(s)', '?').strip()} CPUs"


class Service:
    """``python -m service`` with its defaults but two API keys, on a free port, its log in a
    temporary file."""

    def __init__(self, env: dict[str, str]) -> None:
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log = tempfile.NamedTemporaryFile(prefix="abuse-", suffix=".log", delete=False)  # noqa: SIM115
        keys = {"PLANNER_API_KEYS": f"{ATTACKER},{OTHER}", "PLANNER_PORT": str(self.port)}
        self.process = subprocess.Popen(
            [sys.executable, "-m", "service"],
            env={**os.environ, **env, **keys},
            cwd=ROOT,
            stdout=self.log,
            stderr=subprocess.STDOUT,
        )
        deadline = time.monotonic() + 600  # compiling the kernels afresh takes minutes
        with httpx.Client(base_url=self.url, trust_env=False) as c:
            while time.monotonic() < deadline:
                assert self.process.poll() is None, Path(self.log.name).read_text()
                try:
                    c.get("/healthz", timeout=5)
                    return
                except httpx.TransportError:
                    time.sleep(0.1)
        self.stop()
        raise RuntimeError("the service did not start in 600 s")

    def client(self, key: str = ATTACKER, timeout: float = 300) -> httpx.Client:
        """A client acting for ``key``'s tenant."""
        headers = {"X-API-Key": key}
        return httpx.Client(base_url=self.url, trust_env=False, timeout=timeout, headers=headers)

    def stop(self) -> None:
        self.process.terminate()
        self.process.wait(timeout=30)
        Path(self.log.name).unlink(missing_ok=True)


@dataclass
class Watch:
    """What a watch saw while a pattern ran: ``/healthz``'s slowest answer (every 50 ms, on a
    fresh connection) and its answers that were not 200, the server's peak RSS, and the other
    tenant's small requests (their times and statuses), when it made any."""

    stall: float = 0.0
    failures: int = 0
    peak_rss: float = 0.0
    other: list[float] = field(default_factory=list)
    other_statuses: dict[str, int] = field(default_factory=dict)


def _poll(url: str, pid: int, done: EventType, out: Queue[Watch]) -> None:
    watch = Watch(peak_rss=rss_mb(pid))
    fresh = httpx.Limits(max_keepalive_connections=0)
    with httpx.Client(base_url=url, trust_env=False, timeout=60, limits=fresh) as c:
        while not done.is_set():
            t0 = time.monotonic()
            try:
                ok = c.get("/healthz").status_code == 200
            except httpx.HTTPError:
                ok = False
            watch.stall = max(watch.stall, time.monotonic() - t0)
            watch.peak_rss = max(watch.peak_rss, rss_mb(pid))
            watch.failures += not ok
            done.wait(0.05)
    out.put(watch)


def _small_map(c: httpx.Client, side: int, seed: int) -> httpx.Response:
    """A new ``side`` x ``side`` map (10 % blocked, its first row and last column free) with a
    plan across it."""
    cells = np.random.default_rng(seed).random((side, side)) < 0.1
    cells[0, :] = cells[:, -1] = False
    rows = ["".join("@" if b else "." for b in row) for row in cells]
    return c.post("/maps", json={"rows": rows, "start": [0, 0], "goal": [side - 1, side - 1]})


def _other(url: str, kind: str, ready: EventType, done: EventType, out: Queue[Watch]) -> None:
    """The other tenant, every 0.2 s until ``done``: ``plan-60`` plans across its 60 x 60 map
    (uploaded first) to a goal it moves each time; ``upload-10`` uploads a new 10 x 10 map."""
    watch = Watch()
    headers = {"X-API-Key": OTHER}
    with httpx.Client(base_url=url, trust_env=False, timeout=120, headers=headers) as c:
        map_id = _small_map(c, 60, 60).json()["map_id"] if kind == "plan-60" else ""
        free = [[r, 59] for r in range(59, 29, -1)]
        ready.set()
        seq = 0
        while not done.is_set():
            t0 = time.monotonic()
            try:
                if kind == "plan-60":
                    body = {"map_id": map_id, "start": [0, 0], "goal": free[seq % len(free)]}
                    status = str(c.post("/plan", json=body).status_code)
                else:
                    status = str(_small_map(c, 10, seq).status_code)
            except httpx.HTTPError as exc:
                status = type(exc).__name__
            watch.other.append(time.monotonic() - t0)
            watch.other_statuses[status] = watch.other_statuses.get(status, 0) + 1
            seq += 1
            done.wait(0.2)
    out.put(watch)


@contextlib.contextmanager
def watching(service: Service, other: str | None = None) -> Iterator[list[Watch]]:
    """The :class:`Watch` of the block, in the list yielded once it ends; with ``other`` (a
    kind of :func:`_other`), the other tenant's requests go on throughout the block too."""
    done = Event()
    out: Queue[Watch] = Queue()
    pid = service.process.pid
    workers = [Process(target=_poll, args=(service.url, pid, done, out), daemon=True)]
    if other is not None:
        ready = Event()
        workers.append(
            Process(target=_other, args=(service.url, other, ready, done, out), daemon=True)
        )
    for worker in workers:
        worker.start()
    if other is not None:
        ready.wait(120)
    time.sleep(0.5)
    result: list[Watch] = []
    try:
        yield result
    finally:
        time.sleep(0.2)
        done.set()
        watches = [out.get(timeout=300) for _ in workers]
        for worker in workers:
            worker.join(timeout=30)
        seen = Watch()
        for watch in watches:
            seen.stall = max(seen.stall, watch.stall)
            seen.failures += watch.failures
            seen.peak_rss = max(seen.peak_rss, watch.peak_rss)
            seen.other += watch.other
            seen.other_statuses.update(watch.other_statuses)
        result.append(seen)
