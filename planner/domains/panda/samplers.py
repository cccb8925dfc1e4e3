"""The Panda's four streams, real: top grasps, placements, IK (pybullet's, with restarts and
collision checks) and motion (OMPL RRT-Connect in the arm's 7 joints).

Every sampler but the grasp gets a :class:`~planner.streams.StreamContext`: the blocks' poses and
what the hand holds where its output is first needed. Each query ends in bounded time (attempt and
iteration budgets) and returns outputs or a :class:`~planner.streams.Failure` saying why.
"""

from __future__ import annotations

import logging
import math
import random
from collections import Counter
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field

import pybullet as p

from planner.domains.manipulation.samplers import BlockSamplers, Reach, with_text
from planner.domains.panda.geometry import (
    GRID_GAP,
    PLACEMENT_GAP,
    PandaGeometry,
    Region,
    footprint_half,
    grid_slots,
)
from planner.domains.panda.problem import geometry_of
from planner.domains.panda.values import BlockPose, Conf, Grasp, Trajectory
from planner.domains.panda.world import PandaWorld
from planner.pddl.structs import Problem
from planner.robots.panda.model import LOWER, READY, UPPER, duration, within_limits
from planner.sim.motion import MotionConfig, NoPath, plan_joint_motion
from planner.sim.transforms import Pose, angle_between, multiply, quat_from_yaw, wrap_angle
from planner.streams.adapters import Failure, StreamAdapter

log = logging.getLogger(__name__)

GRASP_YAWS = (0.0, math.pi / 2)  # fingers across the block's y faces, or across its x faces
TALL = 0.06  # a block taller than this is held this far below its top ...
GRASP_BELOW_TOP = 0.025  # ... (the fingers then stay above the blocks around it)
IK_POSITION = 1e-3  # metres an IK solution may miss the tool pose by
IK_ANGLE = 1e-2  # radians, likewise
HAND_BLOCKED = "hand in collision"  # why an IK solution is refused when its hand collides


@dataclass(frozen=True)
class SamplerConfig:
    """Budgets and distances of the Panda's samplers."""

    placement_attempts: int = 30  # poses tried per placement query
    placement_gap: float = PLACEMENT_GAP  # metres kept from the other blocks and the rims
    grid_fraction: float = 0.75  # placement tries on the packing grid, the rest uniform
    grid_gap: float = GRID_GAP  # metres between the packing grid's blocks: room for a finger
    grid_jitter: float = (
        0.0025  # metres a packed block may sit off its slot (open fingers need 3 cm)
    )
    ik_restarts: int = 6  # IK searches per query: the ready pose first, then perturbed ones
    ik_iterations: int = 100  # pybullet IK iterations per search round (3 rounds a search)
    approach: float = 0.10  # the hand comes down onto a block from this far above, metres
    max_straight: float = 0.6  # radians any joint may turn on the straight move down
    clearance: float = 0.01  # metres kept from obstacles along planned motions
    # OMPL for the arm: checks every 0.4% of the joint space's extent (~0.05 rad, ~3 cm at
    # the hand), 150 iterations a search, 20 partial shortcuts.
    motion: MotionConfig = field(
        default_factory=lambda: MotionConfig(resolution=0.004, shortcut_steps=20, iterations=150)
    )

    def with_text(self, name: str, text: str) -> SamplerConfig:
        """This config with its text or number field ``name`` set from ``text``."""
        return with_text(self, name, text)


def grasp_height(size: tuple[float, float, float]) -> float:
    """Where a top grasp holds a block, above its centre: the centre of a small block, just
    below the top of a tall one."""
    return size[2] / 2 - GRASP_BELOW_TOP if size[2] > TALL else 0.0


def tool_target(pose: BlockPose, grasp: Grasp, *, flip: bool = False, lift: float = 0.0) -> Pose:
    """Where the tool goes to hold a block at ``pose`` by ``grasp``, raised by ``lift``."""
    block = ((pose.x, pose.y, pose.z + lift), quat_from_yaw(pose.yaw))
    return multiply(block, grasp.tool_in_block(flip))


class PandaSamplers(BlockSamplers[PandaWorld, BlockPose, Grasp, Conf, Trajectory]):
    """The samplers of one Panda problem, sharing one pybullet world."""

    def __init__(
        self, geometry: PandaGeometry, rng: random.Random, config: SamplerConfig = SamplerConfig()
    ) -> None:
        super().__init__(PandaWorld(geometry), rng, BlockPose, Grasp)
        self.geometry = geometry
        self.config = config

    # --- streams -----------------------------------------------------------------------------

    def sample_grasp(self, block: str) -> tuple[Grasp]:
        size = self.geometry.block(block).size
        return (Grasp(self.rng.choice(GRASP_YAWS), grasp_height(size)),)

    def _placement(self, block: str, region: str) -> tuple[BlockPose] | Failure:
        self.world.hold(None)  # the block is tried where it would stand, not in the hand
        candidates = self._placements(self.geometry.region(region), self.geometry.block(block).size)
        return self._free_place(block, candidates, self.config.placement_gap, f"in {region}")

    def _placements(
        self, reg: Region, size: tuple[float, float, float]
    ) -> Iterator[BlockPose | None]:
        """``placement_attempts`` poses drawn in a region (None: a turn that does not fit)."""
        xmin, xmax, ymin, ymax = reg.footprint()
        cfg = self.config
        for _ in range(cfg.placement_attempts):
            # Mostly square to the region on a grid that starts in its corners and leaves room
            # for a finger between blocks; sometimes anywhere, turned any way.
            grid = self.rng.random() < cfg.grid_fraction
            if grid:
                yaw = self.rng.randrange(4) * math.pi / 2 + self.rng.uniform(-0.05, 0.05)
            else:
                yaw = self.rng.uniform(-math.pi, math.pi)
            hx, hy = footprint_half(size, yaw)
            m = cfg.placement_gap
            if xmax - xmin < 2 * (hx + m) or ymax - ymin < 2 * (hy + m):
                yield None
                continue
            lo_x, hi_x, lo_y, hi_y = xmin + m + hx, xmax - m - hx, ymin + m + hy, ymax - m - hy
            if grid:  # the grid keeps a finger's room from the rims too
                # The grid of the block square to the region (its small turn is in the gap).
                square = (
                    (size[0] / 2, size[1] / 2)
                    if round(yaw / (math.pi / 2)) % 2 == 0
                    else (
                        size[1] / 2,
                        size[0] / 2,
                    )
                )
                xs, ys = grid_slots(reg.footprint(), square, gap=cfg.grid_gap)
                x, y = self.rng.choice(xs), self.rng.choice(ys)
                x = min(hi_x, max(lo_x, x + self.rng.uniform(-cfg.grid_jitter, cfg.grid_jitter)))
                y = min(hi_y, max(lo_y, y + self.rng.uniform(-cfg.grid_jitter, cfg.grid_jitter)))
            else:
                x, y = self.rng.uniform(lo_x, hi_x), self.rng.uniform(lo_y, hi_y)
            yield BlockPose(x, y, reg.top + size[2] / 2, wrap_angle(yaw))

    def _inverse_kinematics(self, reach: Reach[BlockPose, Grasp]) -> tuple[Conf] | Failure:
        block, pose, grasp, placing = reach.block, reach.pose, reach.grasp, reach.placing
        rejected: Counter[str] = Counter()
        for flip in self._flips():
            arm = self.solve_ik(tool_target(pose, grasp, flip=flip))
            if arm is None:
                rejected["out of reach"] += 1
                continue
            above = tool_target(pose, grasp, flip=flip, lift=self.config.approach)
            conf = self._kin(block, grasp, arm, above, placing, rejected)
            if conf is not None:
                return (conf,)
        why = ", ".join(f"{cause} {n}" for cause, n in sorted(rejected.items()))
        # The hand's place is set by the pose and the grasp alone (either way round, it is
        # symmetric): where it collides both ways, no other arm configuration helps.
        hopeless = rejected[HAND_BLOCKED] == 2
        return Failure(f"no arm configuration ({why})", exhausted=hopeless)

    def _flips(self) -> tuple[bool, bool]:
        """Both ways round of the symmetric hand, in a random order."""
        return (False, True) if self.rng.random() < 0.5 else (True, False)

    def _kin(
        self,
        block: str,
        grasp: Grasp,
        arm: tuple[float, ...],
        above: Pose,
        placing: bool,
        rejected: Counter[str],
    ) -> Conf | None:
        """The configuration holding the block with ``arm`` and the hand raised over it, if
        the hand gets down and back up and both ends keep what they must clear."""
        world, cfg = self.world, self.config
        # At the grasp: picking, the open hand around the block; placing, the block in it.
        self._hold(block, grasp, placing)
        world.set_arm(arm)
        if world.hand_collides():
            rejected[HAND_BLOCKED] += 1
            return None
        if world.robot_collides():
            rejected["grasp in collision"] += 1
            return None
        raised = self.solve_ik(above, seed=arm, restarts=1)
        if raised is None or max(abs(a - b) for a, b in zip(arm, raised, strict=True)) > (
            cfg.max_straight
        ):
            rejected["no straight way down"] += 1
            return None
        # Coming down holds what the hand held before the action; going up what it holds after.
        for holding, start, end in ((placing, raised, arm), (not placing, arm, raised)):
            self._hold(block, grasp, holding)
            if not self._straight_free(start, end):
                rejected["way down blocked"] += 1
                world.hold(None)
                return None
        for holding in (False, True):  # motions arrive and leave here, holding and not
            self._hold(block, grasp, holding)
            world.set_arm(raised)
            if world.robot_collides(clearance=cfg.clearance):
                rejected["raised hand within the clearance"] += 1
                world.hold(None)
                return None
        world.hold(None)
        return Conf(arm, raised)

    def _hold(self, block: str, grasp: Grasp, holding: bool) -> None:
        if holding:
            self.world.hold(block, grasp)
        else:
            self.world.hold(None)

    def _straight_free(self, start: tuple[float, ...], end: tuple[float, ...]) -> bool:
        """The joint-space line between two configurations, every 0.02 rad, without collision."""
        step = max(abs(a - b) for a, b in zip(start, end, strict=True))
        n = max(2, math.ceil(step / 0.02))
        for i in range(n + 1):
            t = i / n
            self.world.set_arm(tuple(a + t * (b - a) for a, b in zip(start, end, strict=True)))
            if self.world.robot_collides():
                return False
        return True

    def solve_ik(
        self, tool: Pose, *, seed: tuple[float, ...] | None = None, restarts: int | None = None
    ) -> tuple[float, ...] | None:
        """Joint angles within limits that put the tool at ``tool``, or None: pybullet's
        damped least squares from the ready pose turned towards the target (or from ``seed``),
        then from perturbed starts. Collisions are the caller's to check."""
        world, cfg = self.world, self.config
        c, robot = world.client, world.robot
        n = cfg.ik_restarts if restarts is None else restarts
        (x, y, _), quat = tool
        for attempt in range(n):
            if seed is not None and attempt == 0:
                start = list(seed)
            else:
                start = list(READY)
                start[0] = math.atan2(y, x)
                if attempt > 0:
                    start = [q + self.rng.gauss(0.0, 0.3) for q in start]
                start = [min(hi, max(lo, q)) for q, lo, hi in zip(start, LOWER, UPPER, strict=True)]
            world.set_arm(start)
            solution: tuple[float, ...] = tuple(start)
            for _ in range(3):
                raw = p.calculateInverseKinematics(
                    robot,
                    world.tool_link,
                    tool[0],
                    quat,
                    maxNumIterations=cfg.ik_iterations,
                    residualThreshold=1e-6,
                    physicsClientId=c,
                )
                solution = tuple(float(q) for q in raw[:7])
                world.set_arm(solution)
            if not within_limits(solution):
                continue
            position, orientation = world.tool_pose()
            if (
                math.dist(position, tool[0]) < IK_POSITION
                and angle_between(orientation, quat) < IK_ANGLE
            ):
                return solution
        return None

    def _motion(self, q1: Conf, q2: Conf) -> tuple[Trajectory] | Failure:
        world, cfg = self.world, self.config
        holding = world.held[0] if world.held else None

        def valid(arm: tuple[float, ...]) -> bool:
            world.set_arm(arm)
            return not world.robot_collides(clearance=cfg.clearance)

        path = plan_joint_motion(
            q1.raised, q2.raised, valid, lower=LOWER, upper=UPPER, config=cfg.motion
        )
        if isinstance(path, NoPath):
            return Failure(path.reason)
        full = list(path)
        if full[0] != q1.arm:
            full.insert(0, q1.arm)
        if full[-1] != q2.arm:
            full.append(q2.arm)
        return (Trajectory(tuple(full), duration(full), holding),)


def bindings(
    problem: Problem, rng: random.Random, config: SamplerConfig = SamplerConfig()
) -> Mapping[str, StreamAdapter]:
    """The Panda's samplers for ``problem`` (which carries its geometry in ``values``)."""
    return PandaSamplers(geometry_of(problem), rng, config).bindings()
