"""One parser per shape: every place that takes a point refuses what the strictest refused."""

from __future__ import annotations

import pytest

import planner
from planner.maps.polygons import check_polygon
from planner.parsing import point


@pytest.mark.parametrize("bad", [{"x": 1, "y": 2, "w": 3}, [1, True], [1.0, float("nan")], "xy"])
def test_the_one_point_parser_serves_polygons_and_poses_alike(bad: object) -> None:
    with pytest.raises(planner.InvalidInput):
        point(bad, "p")
    with pytest.raises(planner.InvalidInput):
        check_polygon([bad, (0, 0), (1, 0)], field="polygon")
