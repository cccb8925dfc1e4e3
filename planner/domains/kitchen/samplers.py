"""The kitchen's four streams, real: grasps, placements, IK (pr2-ikfast) and motion (OMPL).

Every sampler gets a :class:`~planner.streams.StreamContext`: the blocks' poses and what the hand
holds at the point of the plan where the output is first needed. Each query ends in bounded time
(an attempt budget) and returns outputs or ``None``.
"""

from __future__ import annotations

import itertools
import logging
import math
import random
from collections import Counter
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

from planner.domains.kitchen.geometry import BlockPose, KitchenGeometry, Platform
from planner.domains.kitchen.problem import ROBOT, geometry_of
from planner.domains.kitchen.routes import BaseRoutes
from planner.domains.kitchen.values import BaseConf, Conf, Grasp, Segment, Trajectory
from planner.domains.kitchen.world import KitchenWorld
from planner.domains.manipulation.problem import block_pose_to_pose
from planner.domains.manipulation.samplers import BlockSamplers, Reach, with_text
from planner.pddl.structs import Problem
from planner.robots import get_robot
from planner.robots.base import path_seconds
from planner.robots.pr2.ik import arm_ik
from planner.robots.pr2.model import (
    ARM_JOINTS,
    BASE_VELOCITY,
    JOINT_LIMITS,
    REST_ARM_CONF,
)
from planner.sim.motion import (
    MotionConfig,
    NoPath,
    plan_base_motion,
    plan_joint_motion,
)
from planner.sim.transforms import invert, multiply, quat_from_euler, wrap_angle
from planner.streams.adapters import Failure, StreamAdapter, StreamContext

log = logging.getLogger(__name__)


BASE_ORDERS = ("around", "straight", "drawn")


@dataclass(frozen=True)
class SamplerConfig:
    """Budgets and distances of the kitchen samplers."""

    placement_attempts: int = 30  # poses tried per placement query
    placement_gap: float = 0.01  # metres kept between blocks on a platform
    # Placement tries on the packing grid, the rest uniform. A kitchen-N stove's grid has N
    # slots or a few more, and one block put off the grid leaves the last ones no room: the
    # blocks placed one after another all fit in 154 of 200 draws on kitchen-20's stove at 1.0,
    # 21 at 0.75 (kitchen-12: 186 and 62). At 0.75 learned spent kitchen-20's 1800 s re-packing
    # the stove (seed 1000: 5,543 placements refused); at 1.0 it plans it, and plans kitchen-12
    # and -16 in 31% and 40% less time (docs/BENCHMARKS.md, why kitchen-20 stalled).
    corner_fraction: float = 1.0
    corner_jitter: float = 0.01  # metres a packed block may sit in from its grid slot
    # Collision-free base poses drawn per IK query, tried nearest first: the more drawn, the
    # nearer the first that works. 96 rather than 12 cut execution by a tenth to a fifth for
    # four times the seconds per IK query (kitchen-4 and kitchen-8, paired, at 2af562f: the
    # figures are in commit beb6d47). At 12 until 2af562f: before it, the learned
    # planner timed out on kitchen-4 seed 1009 with 96, re-sampling the placement before a full
    # stove instead of the ones that had filled it.
    ik_attempts: int = 96
    base_attempts: int = 30  # candidate base poses drawn for each of those
    # The order IK tries its base poses in, given where the robot moves from: "around" by the
    # seconds of the shortest route round the fixtures (routes.py), "straight" by straight-line
    # seconds, "drawn" as drawn.
    base_order: str = "around"
    # Metres the "around" routes keep from a fixture's footprint: the base at rest clears one
    # at 0.36 square to it and 0.50 turned 45 degrees (with the clearance; measured at 1110744).
    route_radius: float = 0.42
    reach: tuple[float, float] = (0.45, 0.85)  # base-to-block distance range, metres
    approach: float = 0.10  # pre-grasp distance along the tool's x axis, metres
    motion: MotionConfig = field(default_factory=MotionConfig)  # OMPL for the base
    # OMPL for the arm: ~2 cm at the gripper between checks. 10 partial shortcuts, not the
    # base's 100: each further shortcut of an arm path cost more planning than it saved
    # execution (measured when b66f9cb made it 10: 100 steps took 1.4 s more per path than 10
    # to save 0.34 s of motion; whole baseline runs 25% faster in total). 100 iterations of an
    # arm search take about 0.17 s on an idle machine (benchmarks/motion_iterations.py).
    arm_motion: MotionConfig = field(
        default_factory=lambda: MotionConfig(resolution=0.002, shortcut_steps=10, iterations=100)
    )
    workspace_margin: float = 1.2  # base may roam this far beyond the fixtures, metres
    clearance: float = 0.015  # metres kept from obstacles along planned motions
    max_straight: float = 0.6  # radians any joint may turn on the straight approach move
    # At an IK solution in collision (at its approach in the clearance), check the gripper and
    # the held block alone: where they are follows from the grasp, not the base or the arm, so
    # if they collide every base pose fails and the query fails at once: the same outcome as
    # the whole loop's, its reason naming the gripper (False: try every base pose). The failure
    # says exhausted: asked again with the same inputs in the same world it would fail again,
    # so the search remembers it and does not ask (as the Panda's hand blocked both ways).
    gripper_first: bool = True

    def __post_init__(self) -> None:
        if self.base_order not in BASE_ORDERS:
            raise ValueError(
                f"unknown base_order {self.base_order!r} (known: {', '.join(BASE_ORDERS)})"
            )

    def with_text(self, name: str, text: str) -> SamplerConfig:
        """This config with its text or number field ``name`` set from ``text`` (as a command
        line gives it); a ValueError says what is wrong."""
        return with_text(self, name, text)


def _grasps(size: float, approach: float) -> list[Grasp]:
    """Four top grasps (tool pointing down) and four side grasps, one per face. Side grasps come
    in tilted down by ``SIDE_PITCH`` so the forearm clears the platform."""
    grasps = []
    for k in range(4):
        yaw = k * math.pi / 2
        top = ((0.0, 0.0, size / 2 - 0.025), quat_from_euler(0.0, math.pi / 2, yaw))
        grasps.append(Grasp("top", top, approach))
    for k in range(4):
        yaw = k * math.pi / 2
        side = ((0.0, 0.0, 0.01), quat_from_euler(0.0, SIDE_PITCH, yaw))
        grasps.append(Grasp("side", side, approach))
    return grasps


SIDE_PITCH = 0.4  # radians below horizontal for side grasps


BASE_HALF_WIDTH = 0.334  # half the PR2 base's side: no fixture may come closer to its centre


def _slots(lo: float, hi: float, pitch: float) -> list[float]:
    """Centres from ``lo`` to ``hi`` (both ends, the platform's edges) at least ``pitch`` apart:
    as many blocks as fit in a row, the outer ones against the edges."""
    n = int((hi - lo) // pitch) + 1 if hi > lo else 1
    if n == 1:
        return [(lo + hi) / 2]
    return [lo + i * (hi - lo) / (n - 1) for i in range(n)]


def _rect_distance(x: float, y: float, rect: tuple[float, float, float, float]) -> float:
    """Distance from a point to an axis-aligned rectangle (0 inside)."""
    xmin, xmax, ymin, ymax = rect
    dx = max(xmin - x, 0.0, x - xmax)
    dy = max(ymin - y, 0.0, y - ymax)
    return math.hypot(dx, dy)


def _arm_duration(path: list[tuple[float, ...]], joints: tuple[str, ...]) -> float:
    return path_seconds(path, get_robot(ROBOT).velocities(joints))


def _base_duration(path: list[BaseConf]) -> float:
    linear, angular = BASE_VELOCITY
    seconds = 0.0
    for a, b in itertools.pairwise(path):
        seconds += max(
            math.hypot(b[0] - a[0], b[1] - a[1]) / linear, abs(wrap_angle(b[2] - a[2])) / angular
        )
    return seconds


def _straight_base_s(a: BaseConf, b: BaseConf) -> float:
    """Seconds of a straight base move from ``a`` to ``b`` under the velocity limits."""
    return _base_duration([a, b])


def _standing_at(context: StreamContext | None) -> BaseConf | None:
    """The base pose the robot stands at where a configuration is first needed (the move to
    it starts there), if the context binds it."""
    if context is None:
        return None
    for (name,) in context.holds("at-conf"):
        value = context.values.get(name)
        if isinstance(value, Conf):
            return value.base
    return None


class KitchenSamplers(BlockSamplers[KitchenWorld, BlockPose, Grasp, Conf, Trajectory]):
    """The samplers of one kitchen problem, sharing one pybullet world."""

    def __init__(
        self,
        geometry: KitchenGeometry,
        rng: random.Random,
        *,
        arm: str = "right",
        config: SamplerConfig = SamplerConfig(),
    ) -> None:
        super().__init__(KitchenWorld(geometry, arm), rng, BlockPose, Grasp)
        self.geometry = geometry
        self.arm = arm
        self.config = config
        xs = [x for p in geometry.platforms for x in p.footprint()[:2]]
        ys = [y for p in geometry.platforms for y in p.footprint()[2:]]
        m = config.workspace_margin
        self.bounds = (min(xs) - m, max(xs) + m, min(ys) - m, max(ys) + m)
        self.lower = tuple(JOINT_LIMITS[j][0] for j in ARM_JOINTS[arm])
        self.upper = tuple(JOINT_LIMITS[j][1] for j in ARM_JOINTS[arm])
        self.rest = REST_ARM_CONF[arm]
        self.routes = BaseRoutes(
            [p.footprint() for p in geometry.platforms],
            config.route_radius,
            tight=BASE_HALF_WIDTH,
            velocity=BASE_VELOCITY,
        )

    # --- streams -----------------------------------------------------------------------------

    def sample_grasp(self, block: str) -> tuple[Grasp]:
        size = self.geometry.block(block).size
        return (self.rng.choice(_grasps(size, self.config.approach)),)

    def _placement(self, block: str, platform: str) -> tuple[BlockPose] | Failure:
        plat = self.geometry.platform(platform)
        size = self.geometry.block(block).size
        xmin, xmax, ymin, ymax = plat.footprint()
        if xmax - xmin < size or ymax - ymin < size:
            return Failure(f"{block} is larger than {platform}")
        candidates = self._placements(plat, size)
        return self._free_place(block, candidates, self.config.placement_gap, f"on {platform}")

    def _placements(self, plat: Platform, size: float) -> Iterator[BlockPose | None]:
        """``placement_attempts`` poses drawn on a platform (None: a turn that does not fit)."""
        xmin, xmax, ymin, ymax = plat.footprint()
        cfg = self.config
        for _ in range(cfg.placement_attempts):
            # Square to the platform on a grid that starts in its corners, so that a small
            # platform (the stove) keeps room for the next block; anywhere for the tries that
            # ``corner_fraction`` leaves uniform.
            corner = self.rng.random() < cfg.corner_fraction
            if corner:
                yaw = wrap_angle(self.rng.randrange(4) * math.pi / 2 + self.rng.uniform(-0.1, 0.1))
            else:
                yaw = self.rng.uniform(-math.pi, math.pi)
            half = size / 2 * (abs(math.cos(yaw)) + abs(math.sin(yaw)))  # of the turned square
            if xmax - xmin < 2 * half or ymax - ymin < 2 * half:
                yield None
                continue
            if corner:
                pitch = 2 * half + cfg.placement_gap + 2 * cfg.corner_jitter
                x = self.rng.choice(_slots(xmin + half, xmax - half, pitch))
                y = self.rng.choice(_slots(ymin + half, ymax - half, pitch))
                x += math.copysign(self.rng.uniform(0.0, cfg.corner_jitter), (xmin + xmax) / 2 - x)
                y += math.copysign(self.rng.uniform(0.0, cfg.corner_jitter), (ymin + ymax) / 2 - y)
            else:
                x = self.rng.uniform(xmin + half, xmax - half)
                y = self.rng.uniform(ymin + half, ymax - half)
            yield BlockPose(x, y, plat.top + size / 2, yaw)

    def _inverse_kinematics(self, reach: Reach[BlockPose, Grasp]) -> tuple[Conf] | Failure:
        block, pose, grasp, placing = reach.block, reach.pose, reach.grasp, reach.placing
        world = self.world
        tool_world = multiply(block_pose_to_pose(pose), grasp.tool_in_block)
        pre_world = multiply(tool_world, ((-grasp.approach, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)))
        torso = self.geometry.robot.torso
        # Picking, the gripper closes around the block; placing, the block rides in it.
        touching = () if placing else (block,)
        bases = self._base_candidates(pose, _standing_at(reach.context))
        if not bases:
            return Failure("no base pose within reach and clear of the fixtures")
        rejected: Counter[str] = Counter()  # why each base pose or IK solution was refused
        check_grasp = check_approach = self.config.gripper_first  # once each per query
        for base in bases:
            world.hold(None)
            if placing:
                world.hold(block, grasp)
            base_pose = ((base[0], base[1], 0.0), quat_from_euler(0.0, 0.0, base[2]))
            tool = multiply(invert(base_pose), tool_world)
            pre = multiply(invert(base_pose), pre_world)
            solutions = arm_ik(self.arm, tool[0], tool[1], torso=torso)[:4]
            if not solutions:
                rejected["out of the arm's reach"] += 1
            for arm in solutions:
                conf = Conf(base, torso, arm)
                world.set_conf(conf)
                if world.robot_collides(ignore=touching):
                    rejected["grasp in collision"] += 1
                    if check_grasp:
                        check_grasp = False
                        if world.gripper_collides(ignore=touching):
                            return Failure(
                                "the gripper collides at the grasp, from any base pose",
                                exhausted=True,
                            )
                    continue
                approach = arm_ik(self.arm, pre[0], pre[1], torso=torso, nearest_to=arm)
                if not approach:
                    rejected["no approach solution"] += 1
                    continue
                if not self._straight_ok(base, torso, approach[0], arm, touching):
                    rejected["approach blocked"] += 1
                    continue
                out = approach[0]
                if not placing and not self._retreat_ok(base, torso, out, arm, block, grasp):
                    rejected["retreat sweeps a block"] += 1
                    continue
                conf = Conf(base, torso, arm, approach[0])
                world.set_conf(conf, approach=True)
                # Motion planning starts and ends here, so it must keep the same clearance.
                if world.robot_collides(clearance=self.config.clearance):
                    rejected["approach within the clearance"] += 1
                    if check_approach:
                        check_approach = False
                        if world.gripper_collides(clearance=self.config.clearance):
                            return Failure(
                                "the gripper is within the clearance at the approach, "
                                "from any base pose",
                                exhausted=True,
                            )
                    continue
                if not placing and not self._lifted_clear(conf, block, grasp):
                    rejected["lifted block within the clearance"] += 1
                    continue
                return (conf,)
        why = ", ".join(f"{cause} {n}" for cause, n in sorted(rejected.items()))
        return Failure(f"no arm configuration from {len(bases)} base poses ({why})")

    def _straight_ok(
        self,
        base: BaseConf,
        torso: float,
        start: tuple[float, ...],
        end: tuple[float, ...],
        touching: tuple[str, ...],
    ) -> bool:
        """The straight joint-space move between approach and grasp: short and collision-free
        (the executed trajectory takes it without planning)."""
        step = max(abs(a - b) for a, b in zip(start, end, strict=True))
        if step > self.config.max_straight:
            return False
        n = max(2, math.ceil(step / 0.02))
        for i in range(1, n):
            t = i / n
            arm = tuple(a + t * (b - a) for a, b in zip(start, end, strict=True))
            self.world.set_conf(Conf(base, torso, arm))
            if self.world.robot_collides(ignore=touching):
                return False
        return True

    def _retreat_ok(
        self,
        base: BaseConf,
        torso: float,
        approach: tuple[float, ...],
        arm: tuple[float, ...],
        block: str,
        grasp: Grasp,
    ) -> bool:
        """Picking, the hand leaves along the same straight line with the block in it: the block
        must not sweep through its neighbours (going in, the hand was empty)."""
        placed = dict(self.world.placed)
        self.world.set_conf(Conf(base, torso, arm))
        self.world.hold(block, grasp)
        try:
            return self._straight_ok(base, torso, arm, approach, ())
        finally:
            self.world.hold(None)
            self.world.set_blocks(placed)

    def _lifted_clear(self, conf: Conf, block: str, grasp: Grasp) -> bool:
        """Picking, the motion away starts back at the approach with the block in the hand: the
        block must keep the motion planner's clearance there too. (Without this check a side
        grasp could lift a block to within 1.5 cm of its neighbour, and every motion from the
        conf then failed at once: 27 motion queries of one kitchen-6 benchmark.)"""
        placed = dict(self.world.placed)
        self.world.hold(block, grasp)
        try:
            self.world.set_conf(conf, approach=True)
            return not self.world.robot_collides(clearance=self.config.clearance)
        finally:
            self.world.hold(None)
            self.world.set_blocks(placed)

    def _base_candidates(self, pose: BlockPose, came_from: BaseConf | None) -> list[BaseConf]:
        """``ik_attempts`` base poses facing the block, within reach and clear of the fixtures.

        Knowing where the robot stands before it moves here, they come nearest first: IK then
        returns the reachable one the robot gets to soonest. "Nearest" is by the shortest route
        round the fixtures (``base_order="around"``), since a pose on the far side of the sink or
        the table is close in a straight line but costs a detour round it; ``"straight"`` orders
        by straight-line seconds. Execution is what this saves, not planning: the same poses are
        tried either way."""
        bases = [self._draw_base(pose) for _ in range(self.config.ik_attempts)]
        found = [b for b in bases if b is not None]
        if came_from is not None and self.config.base_order == "around":
            seconds = self.routes.seconds_from(came_from)
            found.sort(key=seconds)
        elif came_from is not None and self.config.base_order == "straight":
            found.sort(key=lambda b: _straight_base_s(came_from, b))
        return found

    def _draw_base(self, pose: BlockPose) -> BaseConf | None:
        """One base pose facing the block, within reach, its footprint clear of every fixture."""
        lo, hi = self.config.reach
        for _ in range(self.config.base_attempts):
            phi = self.rng.uniform(-math.pi, math.pi)
            d = self.rng.uniform(lo, hi)
            x, y = pose.x - d * math.cos(phi), pose.y - d * math.sin(phi)
            if any(
                _rect_distance(x, y, p.footprint()) < BASE_HALF_WIDTH
                for p in self.geometry.platforms
            ):
                continue
            base = (x, y, wrap_angle(phi + self.rng.uniform(-0.6, 0.6)))
            self.world.set_conf(Conf(base, self.geometry.robot.torso, self.rest))
            if not self.world.robot_collides(clearance=self.config.clearance):
                return base
        return None

    def _motion(self, q1: Conf, q2: Conf) -> tuple[Trajectory] | Failure:
        world = self.world
        joints = ARM_JOINTS[self.arm]
        holding = world.held[0] if world.held else None
        segments: list[Segment] = []
        cfg = self.config.motion

        def arm_valid_at(base: BaseConf) -> Any:
            def valid(arm: tuple[float, ...]) -> bool:
                world.set_conf(Conf(base, q1.torso, arm))
                return not world.robot_collides(clearance=self.config.clearance)

            return valid

        def arm_path(base: BaseConf, a: tuple[float, ...], b: tuple[float, ...]) -> NoPath | None:
            """Plans the arm's move (appending it); why there is none, else None."""
            if max(abs(x - y) for x, y in zip(a, b, strict=True)) < 1e-6:
                return None
            path = plan_joint_motion(
                a,
                b,
                arm_valid_at(base),
                lower=self.lower,
                upper=self.upper,
                config=self.config.arm_motion,
            )
            if isinstance(path, NoPath):
                return path
            segments.append(Segment("arm", (base,), tuple(path), _arm_duration(path, joints)))
            return None

        start_arm = q1.approach_arm if q1.approach_arm is not None else q1.arm
        if q1.approach_arm is not None:  # retreat straight back from the grasp
            straight = [q1.arm, q1.approach_arm]
            segments.append(
                Segment("arm", (q1.base,), tuple(straight), _arm_duration(straight, joints))
            )
        if (failed := arm_path(q1.base, start_arm, self.rest)) is not None:
            return Failure(f"arm to rest: {failed.reason}")
        if math.dist(q1.base[:2], q2.base[:2]) > 1e-6 or abs(wrap_angle(q1.base[2] - q2.base[2])):

            def base_valid(base: BaseConf) -> bool:
                world.set_conf(Conf(base, q1.torso, self.rest))
                return not world.robot_collides(clearance=self.config.clearance)

            path = plan_base_motion(q1.base, q2.base, base_valid, bounds=self.bounds, config=cfg)
            if isinstance(path, NoPath):
                return Failure(f"base: {path.reason}")
            segments.append(Segment("base", tuple(path), (self.rest,), _base_duration(path)))
        end_arm = q2.approach_arm if q2.approach_arm is not None else q2.arm
        if (failed := arm_path(q2.base, self.rest, end_arm)) is not None:
            return Failure(f"arm from rest: {failed.reason}")
        if q2.approach_arm is not None:  # final straight move onto the grasp
            straight = [q2.approach_arm, q2.arm]
            segments.append(
                Segment("arm", (q2.base,), tuple(straight), _arm_duration(straight, joints))
            )
        return (Trajectory(q1, q2, tuple(segments), holding),)


def bindings(
    problem: Problem, rng: random.Random, config: SamplerConfig = SamplerConfig()
) -> Mapping[str, StreamAdapter]:
    """The kitchen's samplers for ``problem`` (which carries its geometry in ``values``), set by
    ``config``."""
    return KitchenSamplers(geometry_of(problem), rng, config=config).bindings()
