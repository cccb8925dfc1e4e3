"""Motion planning with OMPL: RRT-Connect for the base in SE(2) and for an arm in joint space.

The validity checker is a plain Python function (pybullet collision checks live with the
caller). Planners are chosen by name from :data:`PLANNERS`; an unknown name lists the known.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

log = logging.getLogger(__name__)

ou.setLogLevel(ou.LogLevel.LOG_WARN)

PLANNERS: dict[str, Callable[[ob.SpaceInformation], ob.Planner]] = {
    "rrtconnect": og.RRTConnect,
    "rrt": og.RRT,
    "rrtstar": og.RRTstar,
}
DEFAULT_PLANNER = "rrtconnect"  # RRT-Connect, simplified, as in eTAMP and PDDLStream's PR2


@dataclass(frozen=True)
class MotionConfig:
    planner: str = DEFAULT_PLANNER  # OMPL planner by name
    # A search stops after ``iterations`` planner iterations, so that its outcome does not
    # depend on the machine's speed or load (the kitchen base's 150 take about 0.13 s on an
    # idle machine: benchmarks/motion_iterations.py). ``timeout_s`` only guards against a machine
    # so loaded that they would take longer; a search it stops is logged. None: time only.
    iterations: int | None = 150
    timeout_s: float = 10.0
    resolution: float = 0.004  # collision-check step, share of the space extent (~2 cm, 0.05 rad)
    shortcut_steps: int = 100  # random partial shortcuts between two greedy passes (0: none)
    waypoints: int = 0  # interpolate the simplified path to at least this many states (0: keep)

    def __post_init__(self) -> None:
        if self.planner not in PLANNERS:
            raise ValueError(
                f"unknown OMPL planner {self.planner!r} (known: {', '.join(sorted(PLANNERS))})"
            )
        if self.timeout_s <= 0 or not 0 < self.resolution < 1:
            raise ValueError("timeout_s must be positive and resolution in (0, 1)")
        if self.iterations is not None and self.iterations < 1:
            raise ValueError("iterations must be at least 1 (or None: the time limit only)")
        if self.shortcut_steps < 0:
            raise ValueError("shortcut_steps must be >= 0")


@dataclass(frozen=True)
class NoPath:
    """Why a motion search gave no path; falsy, returned in place of the path."""

    reason: str

    def __bool__(self) -> bool:
        return False


_seeded: list[int] = []  # OMPL's random generator takes one seed per process


def seed_ompl(seed: int) -> None:
    """Seed OMPL once per process (it refuses later seeds); later calls are ignored."""
    if _seeded:
        if _seeded[0] != seed:
            log.debug("OMPL already seeded with %d; ignoring seed %d", _seeded[0], seed)
        return
    ou.RNG.setSeed(max(1, seed))
    _seeded.append(seed)


def rough_path(
    ss: og.SimpleSetup, start: ob.State, goal: ob.State, config: MotionConfig, seed: int | None
) -> tuple[og.PathGeometric, bool] | NoPath:
    """The straight move if it is free, else the planner's unshortened path (and True); or
    why there is none."""
    if seed is not None:
        seed_ompl(seed)
    si = ss.getSpaceInformation()
    si.setStateValidityCheckingResolution(config.resolution)
    si.setup()
    for name, state in (("start", start), ("goal", goal)):
        if not si.isValid(state):
            # No path; OMPL's planners would say so on stderr, past the log level, at every
            # such query. (Kitchen-6 asked for some: picks that lifted the block next to its
            # neighbour, which the pick's IK now refuses.)
            log.debug("no motion: the %s state is in collision", name)
            return NoPath(f"the {name} is in collision")
    if si.checkMotion(start, goal):
        # The straight move is free: the shortest path, and no tree to grow.
        return og.PathGeometric(si, start, goal), False
    ss.setPlanner(PLANNERS[config.planner](si))
    checks = 0
    timed_out = False
    started = time.perf_counter()
    deadline = started + config.timeout_s

    def stop() -> bool:
        nonlocal checks, timed_out
        checks += 1
        if config.iterations is not None and checks > config.iterations:
            return True
        timed_out = time.perf_counter() > deadline
        return timed_out

    solved = ss.solve(ob.PlannerTerminationCondition(stop))
    if timed_out and config.iterations is not None:
        log.warning(
            "a motion search hit its %g s guard after %d of %d iterations: on a machine this "
            "loaded, its outcome depends on the load",
            config.timeout_s,
            checks,
            config.iterations,
        )
    log.debug(
        "%s in %d dimensions: %d termination checks in %.3f s, solved: %s",
        config.planner,
        si.getStateDimension(),
        checks,
        time.perf_counter() - started,
        bool(solved),
    )
    if solved and ss.haveExactSolutionPath():
        return ss.getSolutionPath(), True
    if config.iterations is None:
        return NoPath(f"no path in {config.timeout_s:g} s")
    if timed_out:
        return NoPath(
            f"no path before the {config.timeout_s:g} s guard "
            f"({checks - 1} of {config.iterations} iterations)"
        )
    return NoPath(f"no path in {config.iterations} iterations")


def _solve(
    ss: og.SimpleSetup, start: ob.State, goal: ob.State, config: MotionConfig, seed: int | None
) -> og.PathGeometric | NoPath:
    found = rough_path(ss, start, goal, config, seed)
    if isinstance(found, NoPath):
        return found
    path, planned = found
    if planned:
        path = shorten(ss.getSpaceInformation(), path, config.shortcut_steps)
    if config.waypoints:
        path.interpolate(config.waypoints)
    return path


def _greedy_shortcut(si: ob.SpaceInformation, path: og.PathGeometric) -> og.PathGeometric:
    """From each kept state, jump to the farthest later state it sees in a straight line."""
    states = [path.getState(i) for i in range(path.getStateCount())]
    out = og.PathGeometric(si)
    out.append(states[0])
    i = 0
    while i < len(states) - 1:
        j = len(states) - 1
        while j > i + 1 and not si.checkMotion(states[i], states[j]):
            j -= 1
        out.append(states[j])
        i = j
    return out


def shorten(si: ob.SpaceInformation, path: og.PathGeometric, steps: int) -> og.PathGeometric:
    """Shorten a valid path in a bounded number of collision checks.

    A greedy visibility pass, ``steps`` of OMPL's partial shortcuts (random segments, one
    coordinate at a time), and a second greedy pass. The work is counted in steps, not seconds,
    so the result does not depend on the machine's load; OMPL's ``simplifySolution(t)``
    overran its time limit several-fold with a Python validity checker, and its result varied
    with how far it got. On the kitchen's base moves, paired on the same RRT paths when this
    replaced it (380776e), it gave paths 2% shorter in two thirds of the time.
    """
    path = _greedy_shortcut(si, path)
    if steps:
        og.PathSimplifier(si).partialShortcutPath(path, steps, max(1, steps // 3), 0.33)
        path = _greedy_shortcut(si, path)
    return path


BaseConf = tuple[float, float, float]  # x, y, yaw


def plan_base_motion(
    start: BaseConf,
    goal: BaseConf,
    is_valid: Callable[[BaseConf], bool],
    *,
    bounds: tuple[float, float, float, float],
    config: MotionConfig = MotionConfig(),
    seed: int | None = None,
) -> list[BaseConf] | NoPath:
    """A collision-free SE(2) path from start to goal inside (xmin, xmax, ymin, ymax), or why
    there is none."""
    ss, s0, s1 = base_problem(start, goal, is_valid, bounds)
    path = _solve(ss, s0, s1, config, seed)
    if isinstance(path, NoPath):
        return path
    return [(s.getX(), s.getY(), s.getYaw()) for s in path.getStates()]


def base_problem(
    start: BaseConf,
    goal: BaseConf,
    is_valid: Callable[[BaseConf], bool],
    bounds: tuple[float, float, float, float],
) -> tuple[og.SimpleSetup, ob.State, ob.State]:
    """The SE(2) planning problem of a base move: setup, start and goal states."""
    space = ob.SE2StateSpace()
    b = ob.RealVectorBounds(2)
    b.setLow(0, bounds[0])
    b.setHigh(0, bounds[1])
    b.setLow(1, bounds[2])
    b.setHigh(1, bounds[3])
    space.setBounds(b)
    ss = og.SimpleSetup(space)
    ss.setStateValidityChecker(lambda s: is_valid((s.getX(), s.getY(), s.getYaw())))
    s0, s1 = space.allocState(), space.allocState()
    for state, conf in ((s0, start), (s1, goal)):
        state.setX(conf[0])
        state.setY(conf[1])
        state.setYaw(math.remainder(conf[2], 2 * math.pi))
    ss.setStartAndGoalStates(s0, s1)
    return ss, s0, s1


def plan_joint_motion(
    start: Sequence[float],
    goal: Sequence[float],
    is_valid: Callable[[tuple[float, ...]], bool],
    *,
    lower: Sequence[float],
    upper: Sequence[float],
    config: MotionConfig = MotionConfig(),
    seed: int | None = None,
) -> list[tuple[float, ...]] | NoPath:
    """A collision-free joint-space path, or why there is none; all joints bounded (wrap
    continuous ones first)."""
    n = len(start)
    if not len(goal) == len(lower) == len(upper) == n:
        raise ValueError("start, goal, lower and upper must have the same length")
    space = ob.RealVectorStateSpace(n)
    b = ob.RealVectorBounds(n)
    for i in range(n):
        b.setLow(i, lower[i])
        b.setHigh(i, upper[i])
    space.setBounds(b)
    ss = og.SimpleSetup(space)
    ss.setStateValidityChecker(lambda s: is_valid(tuple(s[i] for i in range(n))))
    s0, s1 = space.allocState(), space.allocState()
    for i in range(n):
        s0[i], s1[i] = start[i], goal[i]
    ss.setStartAndGoalStates(s0, s1)
    path = _solve(ss, s0, s1, config, seed)
    if isinstance(path, NoPath):
        return path
    return [tuple(s[i] for i in range(n)) for s in path.getStates()]
