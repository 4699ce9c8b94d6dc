"""How many CPUs this process may use: the cgroup (v2) CPU quota when one is set, else the CPUs
it may run on. A container limited to 2 CPUs on a 64-core host sizes its pool for 2."""

from __future__ import annotations

import math
import os
from pathlib import Path

__all__ = ["CPU_MAX", "available_cpus", "parse_cpu_max"]

CPU_MAX = Path("/sys/fs/cgroup/cpu.max")


def parse_cpu_max(text: str) -> float | None:
    """The CPUs a cgroup v2 ``cpu.max`` allows (``"$QUOTA $PERIOD"``), or None for no quota.

    >>> parse_cpu_max("max 100000"), parse_cpu_max("150000 100000"), parse_cpu_max("50000")
    (None, 1.5, 0.5)
    """
    fields = text.split()
    if not fields or fields[0] == "max":
        return None
    try:
        quota = int(fields[0])
        period = int(fields[1]) if len(fields) > 1 else 100_000
    except ValueError:
        return None
    if quota <= 0 or period <= 0:
        return None
    return quota / period


def available_cpus(cpu_max: Path = CPU_MAX) -> int:
    """The CPUs this process may use: its affinity, capped by the cgroup quota rounded up."""
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    cpus = cpus or 1
    try:
        quota = parse_cpu_max(cpu_max.read_text(encoding="ascii"))
    except OSError:  # no cgroup v2 here
        quota = None
    if quota is not None:
        cpus = min(cpus, max(1, math.ceil(quota)))
    return cpus
