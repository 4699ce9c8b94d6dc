"""Shared fixtures: the Moving AI maps beside the repository and small hand-made grids."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci", max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile("dev", max_examples=30, deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else "dev")

MOVINGAI = Path(__file__).resolve().parents[1].parent / "shared" / "maps" / "movingai"


@pytest.fixture(scope="session")
def movingai() -> Path:
    if not MOVINGAI.is_dir():
        if os.environ.get("CI"):
            pytest.fail(f"Moving AI maps not found at {MOVINGAI}")
        pytest.skip(f"Moving AI maps not found at {MOVINGAI}")
    return MOVINGAI


def grid_from(text: str) -> np.ndarray:
    """A grid from a picture: '#' blocked, anything else free."""
    rows = [line.strip() for line in text.strip().splitlines()]
    return np.array([[ch == "#" for ch in row] for row in rows], dtype=np.uint8)


ROS_MAP_NAMES = ("depot", "tb3_sandbox", "smoothers_world", "TenByTen", "testmap")
ROS_CANDIDATES = [
    Path(__file__).resolve().parents[1].parent,
    Path(__file__).resolve().parents[2].parent,
]


@pytest.fixture(scope="session")
def ros() -> Path:
    """The shared ROS map_server maps (beside the repository, or beside its worktree folder)."""
    for base in ROS_CANDIDATES:
        folder = base / "shared" / "maps" / "ros"
        if folder.is_dir():
            return folder
    if os.environ.get("CI"):
        pytest.fail(f"ROS maps not found under {ROS_CANDIDATES}")
    pytest.skip(f"ROS maps not found under {ROS_CANDIDATES}")
