"""OMPL motion planning: paths avoid obstacles, blocked goals fail in bounded time."""

from __future__ import annotations

import itertools
import math
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor

import pytest
from ompl import base as ob
from ompl import geometric as og

from planner.sim.motion import (
    MotionConfig,
    NoPath,
    base_problem,
    plan_base_motion,
    plan_joint_motion,
    seed_ompl,
    shorten,
)

pytestmark = pytest.mark.slow


def wall(c: tuple[float, float, float]) -> bool:
    """A wall at |x| < 0.3 with a gap at y > 1."""
    return not (abs(c[0]) < 0.3 and c[1] < 1.0)


def inflated_wall(c: tuple[float, float, float]) -> bool:
    """The wall grown by 3 cm, the planner's collision-check step: like the kitchen's clearance,
    the margin that keeps discretely checked straight moves off the true wall."""
    return not (abs(c[0]) < 0.33 and c[1] < 1.03)


def test_base_path_goes_around_the_wall() -> None:
    path = plan_base_motion(
        (-1.0, 0.0, 0.0), (1.0, 0.0, math.pi / 2), inflated_wall, bounds=(-2, 2, -2, 2)
    )
    assert isinstance(path, list)
    assert path[0] == pytest.approx((-1.0, 0.0, 0.0))
    assert path[-1] == pytest.approx((1.0, 0.0, math.pi / 2))
    # Straight segments between waypoints stay clear of the wall, checked densely.
    for a, b in itertools.pairwise(path):
        for i in range(51):
            t = i / 50
            x, y = a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])
            assert wall((x, y, 0.0)), (x, y)
    # Close to the shortest way round (1.23 + 0.66 + 1.23 m past the inflated corners).
    length = sum(math.dist(a[:2], b[:2]) for a, b in itertools.pairwise(path))
    assert length < 1.35 * 3.12


def test_free_straight_move_is_one_segment() -> None:
    path = plan_base_motion((-1, 0, 0), (1.0, 0.5, 0.3), lambda c: True, bounds=(-2, 2, -2, 2))
    assert path == [pytest.approx((-1.0, 0.0, 0.0)), pytest.approx((1.0, 0.5, 0.3))]


def closed(c: tuple[float, float, float]) -> bool:
    return abs(c[0]) > 0.3


@pytest.mark.parametrize(
    ("config", "reason"),
    [
        (MotionConfig(iterations=20), "no path in 20 iterations"),
        (MotionConfig(iterations=None, timeout_s=0.3), "no path in 0.3 s"),
    ],
)
def test_a_blocked_goal_fails_within_its_limit_and_says_which(
    config: MotionConfig, reason: str
) -> None:
    got = plan_base_motion((-1, 0, 0), (1, 0, 0), closed, bounds=(-2, 2, -2, 2), config=config)
    assert got == NoPath(reason)
    assert not got  # falsy, in place of a path


def _through_a_gap(slow_s: float) -> list[tuple[float, float, float]] | None:
    """In a fresh process, OMPL seeded 5: a base move through an 8 cm gap in a wall, the
    first 400 collision checks (the search's) each slowed by ``slow_s``."""
    seed_ompl(5)
    checks = 0

    def valid(c: tuple[float, float, float]) -> bool:
        nonlocal checks
        checks += 1
        if checks <= 400:
            time.sleep(slow_s)
        return not (abs(c[0]) < 0.1 and abs(c[1]) > 0.04)

    return plan_base_motion((-1.0, 0.8, 0.0), (1.0, -0.8, 1.0), valid, bounds=(-2, 2, -2, 2))


def test_a_motion_does_not_depend_on_the_machines_speed() -> None:
    """The search stops after a number of iterations, not seconds: on a machine slowed 1.6 s
    (once a 1 s limit, and no path) the same seed gives the same path."""
    spawn = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(1, mp_context=spawn, max_tasks_per_child=1) as pool:
        fast = pool.submit(_through_a_gap, 0.0).result()
        slow = pool.submit(_through_a_gap, 0.004).result()
    assert isinstance(fast, list)
    assert slow == fast


def test_iterations_must_be_positive() -> None:
    with pytest.raises(ValueError, match="iterations must be at least 1"):
        MotionConfig(iterations=0)


@pytest.mark.parametrize("end", ["start", "goal"])
def test_a_colliding_end_fails_at_once_and_quietly(
    end: str, capfd: pytest.CaptureFixture[str]
) -> None:
    inside = (0.0, 0.0, 0.0)  # in the wall
    start, goal = ((-1.0, 0.0, 0.0), inside) if end == "goal" else (inside, (1.0, 0.0, 0.0))
    assert plan_base_motion(start, goal, wall, bounds=(-2, 2, -2, 2)) == NoPath(
        f"the {end} is in collision"
    )
    # The failed query is the planner's answer; OMPL's own error lines never reach the console.
    assert capfd.readouterr().err == ""


def test_joint_path_respects_bounds_and_obstacle() -> None:
    def valid(q: tuple[float, ...]) -> bool:
        return not (0.4 < q[0] < 0.6 and q[1] < 0.9)

    path = plan_joint_motion((0.0, 0.0), (1.0, 0.0), valid, lower=(-1, -1), upper=(2, 2))
    assert isinstance(path, list) and path[-1] == pytest.approx((1.0, 0.0))
    assert all(-1 <= v <= 2 for q in path for v in q)
    assert any(q[1] >= 0.9 for q in path)  # it went over the obstacle


def _zigzag_round_the_wall() -> tuple[ob.SpaceInformation, og.PathGeometric]:
    ss, _, _ = base_problem((-1, 0, 0), (1, 0, 0), inflated_wall, (-2, 2, -2, 2))
    si = ss.getSpaceInformation()
    si.setStateValidityCheckingResolution(0.004)
    si.setup()
    path = og.PathGeometric(si)
    for x, y in ((-1, 0), (-1.5, 1.5), (-0.5, 1.3), (0, 1.8), (0.2, 1.4), (1.5, 1.2), (1, 0)):
        state = si.getStateSpace().allocState()
        state.setX(x)
        state.setY(y)
        state.setYaw(0.0)
        path.append(state)
    return si, path


def _xy(path: og.PathGeometric) -> list[tuple[float, float]]:
    states = [path.getState(i) for i in range(path.getStateCount())]
    return [(s.getX(), s.getY()) for s in states]


def _length(points: list[tuple[float, float]]) -> float:
    return sum(math.dist(a, b) for a, b in itertools.pairwise(points))


def test_shortening_pulls_a_detour_tight_and_keeps_it_valid() -> None:
    si, raw = _zigzag_round_the_wall()  # 6.37 m; the shortest way round is 3.12 m
    greedy = _xy(shorten(si, raw, 0))
    si, raw = _zigzag_round_the_wall()
    tight = _xy(shorten(si, raw, 100))
    for points in (greedy, tight):
        assert points[0] == pytest.approx((-1, 0)) and points[-1] == pytest.approx((1, 0))
        for a, b in itertools.pairwise(points):
            for i in range(51):
                t = i / 50
                assert wall((a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), 0.0))
    # Visibility jumps alone cut the corners between visible vertices; the partial shortcuts
    # then pull the path onto the wall's corners.
    assert _length(greedy) < 0.7 * 6.37
    assert _length(tight) < 1.15 * 3.12 < _length(greedy)


def test_unknown_planner_lists_the_known() -> None:
    with pytest.raises(ValueError, match=r"unknown OMPL planner 'prm' .known: rrt, rrtconnect"):
        MotionConfig(planner="prm")
