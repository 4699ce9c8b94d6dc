"""``python -m planner``: plan, scen, simulate and demo."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

import planner
from planner.cli import EXAMPLE_MAP, main
from tests import naive_poses


def run_cli(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(args)
    out, err = capsys.readouterr()
    return code, out, err


def test_plan_prints_one_json_object(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run_cli(
        ["plan", str(EXAMPLE_MAP), "--start", "7", "2", "--goal", "7", "26", "--param", "alpha=4"],
        capsys,
    )
    assert code == 0
    result = json.loads(out)
    assert result["path"][0] == [7, 2]
    assert result["path"][-1] == [7, 26]
    assert result["params"]["alpha"] == 4.0
    assert result["tunnels"] > 0
    assert {"length", "arc_cost", "gates", "narrow_fallback", "min_clearance"} <= set(result)


def test_plan_error_names_the_value(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run_cli(
        ["plan", str(EXAMPLE_MAP), "--start", "0", "0", "--goal", "7", "26"], capsys
    )
    assert code == 2
    assert "start [0, 0] is on an obstacle" in err


def test_simulate_prints_metrics(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["simulate", str(EXAMPLE_MAP), "--start", "7", "2", "--goal", "7", "26"]
    code, out, _ = run_cli(
        [*args, "--dynamic-count", "5", "--seed", "3", "--preset", "wfs-mmas"], capsys
    )
    assert code == 0
    metrics = json.loads(out)
    assert metrics["collisions"] == 0
    assert metrics["reached"] is True


def test_scen_exits_non_zero_on_a_mismatch(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "m.map").write_text("type octile\nheight 1\nwidth 4\nmap\n....\n")
    (tmp_path / "m.map.scen").write_text(
        "version 1\n0\tm.map\t4\t1\t0\t0\t3\t0\t3\n0\tm.map\t4\t1\t0\t0\t2\t0\t9\n"
    )
    code, out, _ = run_cli(["scen", str(tmp_path / "m.map.scen")], capsys)
    summary = json.loads(out)
    assert code == 1
    assert (summary["lines"], summary["solved"], summary["mismatches"]) == (2, 2, 1)
    assert summary["max_abs_error"] == 7.0
    code, out, _ = run_cli(["scen", str(tmp_path / "m.map.scen"), "--limit", "1"], capsys)
    assert json.loads(out)["lines"] == 1
    assert code == 0


def test_demo_runs_as_a_module() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "planner", "demo"], capture_output=True, text=True, check=True
    )
    assert "shortest" in done.stdout
    assert "wide" in done.stdout


def test_plan_on_a_ros_map_in_meters(
    ros: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out_png = tmp_path / "plan.png"
    args = ["plan", "--map", str(ros / "depot.yaml"), "--start", "2.0,3.0", "--goal", "25,10"]
    code, out, _ = run_cli(
        [*args, "--robot-radius", "0.22", "--json", "--png", str(out_png)], capsys
    )
    assert code == 0
    preview = json.loads(out)
    assert {"path", "path_xy", "length", "length_m", "min_clearance_m", "mean_clearance_m"} <= set(
        preview
    )
    assert preview["min_clearance_m"] > 0.22
    start_xy, goal_xy = preview["path_xy"][0], preview["path_xy"][-1]
    half = 0.025 + 1e-9  # half a cell: the center of the cell holding the point
    assert start_xy == pytest.approx([2.0, 3.0], abs=half)
    assert goal_xy == pytest.approx([25.0, 10.0], abs=half)
    assert out_png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    code, out, _ = run_cli([*args, "--robot-radius", "0.22"], capsys)
    assert code == 0
    assert "length" in out
    assert "m (robot radius 0.22 m)" in out


def test_plan_on_a_ros_map_errors_are_one_line(ros: Path, tmp_path: Path) -> None:
    (tmp_path / "m.yaml").write_text("image: gone.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    cases = [
        (["--map", str(tmp_path / "m.yaml"), "--start", "0,0", "--goal", "1,1"], "gone.pgm"),
        (
            ["--map", str(ros / "depot.yaml"), "--start", "2,3", "--goal", "250,10"],
            "outside the map",
        ),
        (["--map", str(ros / "depot.yaml"), "--start", "two,3", "--goal", "25,10"], "X,Y"),
        (
            [
                "--map",
                str(ros / "depot.yaml"),
                "--start",
                "0.05,0.05",
                "--goal",
                "25,10",
                "--robot-radius",
                "0.22",
            ],
            "START_OCCUPIED",
        ),
    ]
    for args, needle in cases:
        done = subprocess.run(
            [sys.executable, "-m", "planner", "plan", *args],
            capture_output=True,
            text=True,
            check=False,
        )
        assert done.returncode == 2, done.stderr
        assert needle in done.stderr
        assert "Traceback" not in done.stderr
        assert len(done.stderr.strip().splitlines()) == 1, done.stderr


def test_simulate_takes_the_obstacle_motion(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["simulate", str(EXAMPLE_MAP), "--start", "7", "2", "--goal", "7", "26"]
    code, out, _ = run_cli(
        [*args, "--dynamic-count", "8", "--obstacle-motion", "simultaneous"], capsys
    )
    assert code == 0
    metrics = json.loads(out)
    assert metrics["obstacle_motion"] == "simultaneous"
    assert metrics["collisions"] == 0


def _console_script() -> Path:
    """The ``planner`` script that ``pip install`` put beside this interpreter."""
    script = Path(sys.executable).parent / "planner"
    assert script.is_file(), f"{script} is missing: pip install -e . (make does) installs it"
    return script


@pytest.mark.parametrize("args", [["--help"], ["demo"], ["plan", "--help"]])
def test_the_console_script_prints_what_the_module_prints(args: list[str]) -> None:
    def run(command: list[str]) -> str:
        done = subprocess.run(command + args, capture_output=True, text=True, check=True)
        assert not done.stderr
        return done.stdout

    script = run([str(_console_script())])
    module = run([sys.executable, "-m", "planner"])
    assert script.strip()
    if "--help" in args:  # the usage line names the program it was called as
        assert script.startswith("usage: planner ")
        script = script.replace("usage: planner ", "usage: python -m planner ", 1)
        # argparse wraps the usage line by its length: compare the words
        assert script.split() == module.split()
    else:
        assert script == module


def test_plan_prints_poses_and_a_nav_msgs_path(
    ros: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["plan", "--map", str(ros / "depot.yaml"), "--robot-radius", "0.22"]
    args += ["--start", "2.0,3.0", "--goal", "25,10,1.5"]
    code, out, _ = run_cli([*args, "--json"], capsys)
    assert code == 0
    preview = json.loads(out)
    poses = [[p["x"], p["y"], p["yaw"]] for p in preview["poses"]]
    assert poses[0][:2] == [2.0, 3.0]
    assert poses[-1] == [25.0, 10.0, 1.5]
    assert preview["length_poses_m"] <= preview["length_m"] + 0.1
    assert preview["goal_used"] is None
    m = planner.read_ros_map(ros / "depot.yaml")
    cs = planner.configuration_space(m, robot_radius=0.22)
    check = naive_poses.check_poses(
        poses, preview["path"], cs.distance, resolution=m.resolution, origin=m.origin,
        robot_radius=0.22, start=(2.0, 3.0), goal=(25.0, 10.0), goal_yaw=1.5,
    )  # fmt: skip
    assert check.problems == []
    code, out, _ = run_cli([*args, "--format", "nav_msgs", "--frame-id", "odom"], capsys)
    assert code == 0
    path = json.loads(out)
    assert path["header"]["frame_id"] == "odom"
    assert len(path["poses"]) == len(poses)
    q = path["poses"][-1]["pose"]["orientation"]
    assert (q["z"], q["w"]) == pytest.approx((math.sin(0.75), math.cos(0.75)))
    code, _, err = run_cli([*args, "--format", "nav_msgs", "--frame-id", "a b"], capsys)
    assert code == 2
    assert "frame_id" in err


def test_plan_on_a_map_file_with_a_goal_tolerance(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["plan", str(EXAMPLE_MAP), "--start", "7", "2", "--goal", "0", "0"]
    code, _, err = run_cli(args, capsys)
    assert code == 2
    assert "obstacle" in err
    code, out, _ = run_cli([*args, "--goal-tolerance", "3", "--json"], capsys)
    assert code == 0
    preview = json.loads(out)
    assert preview["goal_used"] is not None
    assert 0 < preview["goal_offset_m"] <= 3
    assert preview["poses"][-1]["x"] == preview["goal_used"]["x"]


def test_negative_points_are_points_not_options(
    ros: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--start -12.5,22.0``: argparse would read the word as an unknown option."""
    shifted = tmp_path / "depot.yaml"  # the depot, moved so that its points are negative
    shifted.write_text(f"image: {ros / 'depot.pgm'}\nresolution: 0.05\norigin: [-27.0, -13.0, 0]\n")
    for start, goal in (("-25.0,-10.0", "-2,-3"), ("-25.0,-10.0,-1.5", "-2.0,-3.0")):
        code, out, err = run_cli(
            ["plan", "--map", str(shifted), "--start", start, "--goal", goal, "--json"], capsys
        )
        assert code == 0, err
        path_xy = json.loads(out)["path_xy"]
        assert path_xy[0] == pytest.approx([-25.0, -10.0], abs=0.025 + 1e-9)
        assert path_xy[-1] == pytest.approx([-2.0, -3.0], abs=0.025 + 1e-9)
