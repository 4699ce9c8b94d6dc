"""``planner.warm_up`` compiles the kernels a step calls from Python: a service's first step
must not compile one on its event loop."""

from __future__ import annotations

import subprocess
import sys

from tests.service.conftest import ROOT

STEP_KERNELS = (
    "planner.poses.polyline._poses",
    "planner.fleets.roadmap._attach",
    "planner.fleets.pibt._pibt",
    "planner.stepping.obstacles._first_outside",
)
"""Kernels a step (a lone robot's, a fleet robot's) calls from Python."""


def test_the_kernels_of_a_step_are_compiled_by_warm_up() -> None:
    script = f"""
import importlib, planner
planner.warm_up()
for name in {STEP_KERNELS!r}:
    module, _, kernel = name.rpartition(".")
    assert getattr(importlib.import_module(module), kernel).signatures, name
"""
    done = subprocess.run(
        [sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr[-2000:]
