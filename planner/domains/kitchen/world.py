"""The kitchen in pybullet: fixtures, blocks and the generated PR2, with collision queries."""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping

import pybullet as p

from planner.domains.kitchen.geometry import BlockPose, KitchenGeometry, block_pose_to_pose
from planner.domains.kitchen.values import Conf, Grasp
from planner.robots.pr2.dimensions import BASE_LINK
from planner.robots.pr2.model import (
    ARM_JOINTS,
    ARM_LINKS,
    ARMS,
    REST_ARM_CONF,
    TOOL_LINK,
    TORSO_JOINT,
    URDF_PATH,
)
from planner.sim import bodies
from planner.sim.collision import Attached, CollisionConfig, Obstacles, RobotCollision
from planner.sim.transforms import Pose, invert, multiply, planar_pose

log = logging.getLogger(__name__)

PENETRATION = -0.001  # bodies overlapping by more than 1 mm collide; resting contact does not
COLLISION = CollisionConfig()  # how robot_collides finds its answer: broad phase, pair filter


class KitchenWorld:
    """One pybullet client holding a kitchen scene; call :meth:`close` (or use ``with``).

    ``collision`` sets how :meth:`robot_collides` finds its answer (the answer is the same).
    """

    def __init__(
        self, geometry: KitchenGeometry, arm: str, *, collision: CollisionConfig = COLLISION
    ) -> None:
        self.geometry = geometry
        self.arm = arm
        self.client = bodies.connect()
        c = self.client
        self.fixtures: dict[str, int] = {}
        for plat in geometry.platforms:
            (cx, cy), (sx, sy, h) = plat.center, plat.size
            self.fixtures[plat.name] = bodies.add_box(
                c, (sx / 2, sy / 2, h / 2), ((cx, cy, h / 2), (0, 0, 0, 1)), plat.color
            )
        self.blocks: dict[str, int] = {}
        for block in geometry.blocks:
            half = block.size / 2
            self.blocks[block.name] = bodies.add_box(
                c, (half, half, half), ((0, 0, -10.0 - len(self.blocks)), (0, 0, 0, 1)), block.color
            )
        # The planner's world never draws: without the visual meshes the robot loads in 20 ms
        # instead of 0.4 s for the first world of a process (pybullet parses each mesh file).
        self.robot = int(
            p.loadURDF(
                str(URDF_PATH),
                useFixedBase=True,
                flags=p.URDF_IGNORE_VISUAL_SHAPES,
                physicsClientId=c,
            )
        )
        joints = bodies.joint_indices(c, self.robot)
        links = bodies.link_indices(c, self.robot)
        self.arm_joints = [joints[n] for n in ARM_JOINTS[arm]]
        self.torso_joint = joints[TORSO_JOINT]
        self.tool_link = links[TOOL_LINK[arm]]
        self.arm_links = [links[n] for n in ARM_LINKS[arm]]
        self.base_links = [-1, links[BASE_LINK]]
        self._base_links = tuple(self.base_links)
        for other in ARMS:
            bodies.set_joints(
                c, self.robot, [joints[n] for n in ARM_JOINTS[other]], REST_ARM_CONF[other]
            )
        # The working arm's links against the base (the other arm, torso and head are not
        # checked against it); the held block against the base, and both against everything.
        self.collision = RobotCollision(
            c,
            self.robot,
            self_pairs=[(link, base) for link in self.arm_links for base in self.base_links],
            config=collision,
        )
        self.held: tuple[str, Grasp] | None = None
        self._block_in_tool: Pose | None = None  # the held block in the tool frame
        self._placed: dict[str, BlockPose] = {}
        # The obstacles robot_collides checks, per held block and ignored blocks, with their
        # boxes; forgotten whenever a block may have moved (set_blocks, another block held).
        self._obstacles: dict[tuple[str | None, frozenset[str]], Obstacles] = {}
        # What pybullet holds now, so that a set_* call only resets what changed (a base move
        # leaves the joints alone, an arm move the base): None until first set.
        self._base: tuple[float, float, float] | None = None
        self._torso: float | None = None
        self._arm: tuple[float, ...] | None = None

    def __enter__(self) -> KitchenWorld:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        bodies.disconnect(self.client)

    # --- state -------------------------------------------------------------------------------

    def set_blocks(self, poses: Mapping[str, BlockPose]) -> None:
        """Put the given blocks at their poses and every other block out of the way."""
        self._placed = dict(poses)
        self._obstacles.clear()
        for i, (name, body) in enumerate(self.blocks.items()):
            if name in poses:
                bodies.set_pose(self.client, body, block_pose_to_pose(poses[name]))
            elif self.held is None or self.held[0] != name:
                bodies.set_pose(self.client, body, ((0, 0, -10.0 - i), (0, 0, 0, 1)))

    def hold(self, block: str | None, grasp: Grasp | None = None) -> None:
        """Attach a block to the gripper (it then follows every :meth:`set_conf`)."""
        held = None if block is None or grasp is None else (block, grasp)
        if (None if held is None else held[0]) != (None if self.held is None else self.held[0]):
            self._obstacles.clear()  # a block let go of stays where the hand left it
        self.held = held
        self._block_in_tool = None if held is None else invert(held[1].tool_in_block)

    def set_base(self, base: tuple[float, float, float]) -> None:
        self._put_base(base)
        self._update_held()

    def set_arm(self, arm: tuple[float, ...]) -> None:
        self._put_arm(arm)
        self._update_held()

    def set_conf(self, conf: Conf, *, approach: bool = False) -> None:
        self._put_base(conf.base)
        if conf.torso != self._torso:
            bodies.set_joints(self.client, self.robot, [self.torso_joint], [conf.torso])
            self._torso = conf.torso
        self._put_arm(conf.approach_arm if approach and conf.approach_arm is not None else conf.arm)
        self._update_held()

    def _put_base(self, base: tuple[float, float, float]) -> None:
        if base != self._base:
            bodies.set_pose(self.client, self.robot, planar_pose(*base))
            self._base = (base[0], base[1], base[2])

    def _put_arm(self, arm: tuple[float, ...]) -> None:
        if arm != self._arm:
            p.resetJointStatesMultiDof(
                self.robot, self.arm_joints, [[q] for q in arm], physicsClientId=self.client
            )
            self._arm = tuple(arm)

    def tool_pose(self) -> Pose:
        return bodies.link_pose(self.client, self.robot, self.tool_link)

    def _update_held(self) -> None:
        if self.held is None or self._block_in_tool is None:
            return
        pose = multiply(self.tool_pose(), self._block_in_tool)
        bodies.set_pose(self.client, self.blocks[self.held[0]], pose)

    # --- collisions --------------------------------------------------------------------------

    def robot_collides(self, *, ignore: Iterable[str] = (), clearance: float = 0.0) -> bool:
        """The robot (and what it holds) against fixtures, placed blocks and its own base.

        ``ignore`` names blocks the gripper may touch (the one it is about to grasp). Without
        ``clearance`` resting contact is allowed and only overlaps over 1 mm count; planners ask
        for a clearance so that what they plan between checked states stays free too.
        """
        held = self.held[0] if self.held else None
        key = (held, frozenset(ignore))
        obstacles = self._obstacles.get(key)
        if obstacles is None:
            members = list(self.fixtures.values()) + [
                self.blocks[n] for n in self._placed if n not in key[1] and n != held
            ]
            obstacles = self._obstacles[key] = Obstacles(self.client, members)
        return self.collision.collides(
            obstacles,
            margin=clearance if clearance > 0 else PENETRATION,
            attached=None if held is None else Attached(self.blocks[held], self._base_links),
        )

    def block_collides(self, name: str, *, margin: float) -> bool:
        """Block ``name`` (at its current pose) against the other placed blocks, with margin."""
        body = self.blocks[name]
        return any(
            bodies.in_contact(self.client, body, self.blocks[o], margin=margin)
            for o in self._placed
            if o != name
        )
