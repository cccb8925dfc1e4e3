"""Base routes round the kitchen's fixtures: what IK orders its base poses by."""

from __future__ import annotations

import math

import pytest

from planner.domains.kitchen.routes import BaseRoutes, grown

TABLE = (0.8, 1.4, -0.6, 0.6)  # kitchen-8's footprints: xmin, xmax, ymin, ymax
SINK = (-0.15, 0.15, 1.0, 1.3)
STOVE = (-0.15, 0.15, -1.3, -1.0)


def _routes(radius: float = 0.42) -> BaseRoutes:
    return BaseRoutes([TABLE, SINK, STOVE], radius, tight=0.334, velocity=(0.5, 1.0))


def test_a_clear_straight_line_is_the_route() -> None:
    metres = _routes().distances_from((0.0, 0.0))
    assert metres((0.3, 0.4)) == pytest.approx(0.5)


def test_the_far_side_of_the_sink_costs_the_detour() -> None:
    """South of the sink to north of it: the straight line crosses the sink, the route goes
    round its west side (the gap between sink and table is too narrow at 0.42 m)."""
    start, goal = (0.0, 0.55), (0.0, 1.75)
    metres = _routes().distances_from(start)(goal)
    assert metres > math.dist(start, goal) + 0.5
    # Round the west side: out to x = -(0.15 + 0.42) and back, at least.
    assert metres > 2 * math.hypot(0.57, 0.6)


def test_a_wider_radius_shuts_the_gap_between_table_and_sink() -> None:
    """From the table's west side to the north-east of the sink: through the gap between the
    table's corner and the sink's with a narrow radius, round the sink's west side with 0.42."""
    start, goal = (0.35, 0.2), (0.55, 1.55)
    narrow = _routes(0.34).distances_from(start)(goal)
    wide = _routes(0.42).distances_from(start)(goal)
    assert narrow < 2.0 < wide


def test_seconds_take_the_turn_when_it_is_longer() -> None:
    seconds = _routes().seconds_from((0.0, 0.0, 0.0))
    assert seconds((0.1, 0.0, math.pi)) == pytest.approx(math.pi)
    assert seconds((0.3, -0.2, 0.1)) == pytest.approx(math.hypot(0.3, 0.2) / 0.5)


def test_grown_octagons_sit_inside_and_round_the_rounded_footprint() -> None:
    inner, outer = grown(SINK, 0.4), grown(SINK, 0.4, outer=True)
    corner = (0.15, 1.3)
    # Every vertex of the inner octagon is within 0.4 of the footprint; the outer one's
    # diagonal cut is 0.4 from the corner.
    for x, y in inner:
        d = math.hypot(max(SINK[0] - x, 0, x - SINK[1]), max(SINK[2] - y, 0, y - SINK[3]))
        assert d <= 0.4 + 1e-9
    cut = (outer[3], outer[4])  # the north-east cut
    mid = ((cut[0][0] + cut[1][0]) / 2, (cut[0][1] + cut[1][1]) / 2)
    assert math.dist(mid, corner) == pytest.approx(0.4)


def test_radius_below_the_tight_one_is_refused() -> None:
    with pytest.raises(ValueError, match="tight"):
        BaseRoutes([TABLE], 0.2, tight=0.334, velocity=(0.5, 1.0))
