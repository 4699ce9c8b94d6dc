"""Robot shapes on the command line and in pictures: ``planner plan`` with ``--footprint``,
``--motion`` and ``--min-turning-radius`` answers the car's poses with their directions; a
plan's picture outlines the footprint along its poses, orange where it reverses."""

from __future__ import annotations

import io
import json
import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import planner
from planner.cli import main
from planner.render_shapes import FORWARD, REVERSE
from tests import naive_shapes
from tests.naive_shapes import RECTANGLE

DEPOT = Path(__file__).resolve().parents[2] / "examples" / "maps" / "depot.yaml"


def test_the_cli_plans_a_car(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "car.png"
    code = main([
        "plan", "--map", str(DEPOT), "--start", "3,3,0", "--goal", "26,12,1.5",
        "--footprint", json.dumps(RECTANGLE), "--motion", "car", "--min-turning-radius", "0.5",
        "--format", "json", "--png", str(out),
    ])  # fmt: skip
    assert code == 0
    preview = json.loads(capsys.readouterr().out)
    poses = np.array([[p["x"], p["y"], p["yaw"]] for p in preview["poses"]])
    assert {p["direction"] for p in preview["poses"]} == {1}
    assert naive_shapes.curvatures(poses).max() <= 2.0 + 1e-6
    depot = planner.read_ros_map(DEPOT)
    assert naive_shapes.motion_hits(RECTANGLE, naive_shapes.blocked_centers(depot), poses) == []
    assert abs(math.remainder(poses[-1, 2] - 1.5, 2 * math.pi)) < 1e-9
    picture = np.asarray(Image.open(out).convert("RGB"))
    assert (picture == FORWARD).all(axis=2).any()


def test_a_bad_footprint_on_the_cli_names_it(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["plan", "--map", str(DEPOT), "--start", "3,3,0", "--goal", "8,3,0"]
    assert main([*args, "--footprint", "[[0.3, 0.2], [0.3"]) == 2
    assert "--footprint must be JSON" in capsys.readouterr().err
    assert main([*args, "--footprint", "[[0, 0], [1, 1], [2, 2]]"]) == 2
    assert "footprint" in capsys.readouterr().err


def _pixels(png: bytes, colour: tuple[int, int, int]) -> int:
    rgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
    return int((rgb == colour).all(axis=2).sum())


def test_the_picture_outlines_the_footprint_forward_and_reverse() -> None:
    bay, start, goal = naive_shapes.parking_bay()
    car = planner.plan(
        bay, start, goal, footprint=RECTANGLE, motion="car_reverse", min_turning_radius=0.5
    )
    png = planner.render_plan(car, cell=6)
    assert _pixels(png, FORWARD) > 100
    assert _pixels(png, REVERSE) > 100  # it backs into the bay
    disc = planner.plan(bay, start, {"x": 6.0, "y": 1.5}, robot_radius=0.2)
    plain = planner.render_plan(disc, cell=6)
    assert _pixels(plain, FORWARD) == 0  # a disc has no outline along its poses
    assert _pixels(planner.render_plan(car, cell=6, poses=False), REVERSE) == 0
