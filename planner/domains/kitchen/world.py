"""The kitchen in pybullet: fixtures, blocks and the generated PR2, with collision queries."""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping

import pybullet as p

from planner.domains.kitchen.geometry import BlockPose, KitchenGeometry, block_pose_to_pose
from planner.domains.kitchen.values import Conf, Grasp
from planner.sim import bodies
from planner.sim.pr2_model import (
    ARM_JOINTS,
    ARM_LINKS,
    ARMS,
    BASE_LINK,
    REST_ARM_CONF,
    TOOL_LINK,
    TORSO_JOINT,
    URDF_PATH,
)
from planner.sim.transforms import Pose, invert, multiply, planar_pose

log = logging.getLogger(__name__)

PENETRATION = -0.001  # bodies overlapping by more than 1 mm collide; resting contact does not


class KitchenWorld:
    """One pybullet client holding a kitchen scene; call :meth:`close` (or use ``with``)."""

    def __init__(self, geometry: KitchenGeometry, arm: str) -> None:
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
        for other in ARMS:
            bodies.set_joints(
                c, self.robot, [joints[n] for n in ARM_JOINTS[other]], REST_ARM_CONF[other]
            )
        self.held: tuple[str, Grasp] | None = None
        self._placed: dict[str, BlockPose] = {}

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
        for i, (name, body) in enumerate(self.blocks.items()):
            if name in poses:
                bodies.set_pose(self.client, body, block_pose_to_pose(poses[name]))
            elif self.held is None or self.held[0] != name:
                bodies.set_pose(self.client, body, ((0, 0, -10.0 - i), (0, 0, 0, 1)))

    def hold(self, block: str | None, grasp: Grasp | None = None) -> None:
        """Attach a block to the gripper (it then follows every :meth:`set_conf`)."""
        self.held = None if block is None or grasp is None else (block, grasp)

    def set_base(self, base: tuple[float, float, float]) -> None:
        bodies.set_pose(self.client, self.robot, planar_pose(*base))
        self._update_held()

    def set_arm(self, arm: tuple[float, ...]) -> None:
        bodies.set_joints(self.client, self.robot, self.arm_joints, arm)
        self._update_held()

    def set_conf(self, conf: Conf, *, approach: bool = False) -> None:
        bodies.set_pose(self.client, self.robot, planar_pose(*conf.base))
        bodies.set_joints(self.client, self.robot, [self.torso_joint], [conf.torso])
        arm = conf.approach_arm if approach and conf.approach_arm is not None else conf.arm
        bodies.set_joints(self.client, self.robot, self.arm_joints, arm)
        self._update_held()

    def tool_pose(self) -> Pose:
        return bodies.link_pose(self.client, self.robot, self.tool_link)

    def _update_held(self) -> None:
        if self.held is None:
            return
        name, grasp = self.held
        pose = multiply(self.tool_pose(), invert(grasp.tool_in_block))
        bodies.set_pose(self.client, self.blocks[name], pose)

    # --- collisions --------------------------------------------------------------------------

    def robot_collides(self, *, ignore: Iterable[str] = (), clearance: float = 0.0) -> bool:
        """The robot (and what it holds) against fixtures, placed blocks and its own base.

        ``ignore`` names blocks the gripper may touch (the one it is about to grasp). Without
        ``clearance`` resting contact is allowed and only overlaps over 1 mm count; planners ask
        for a clearance so that what they plan between checked states stays free too.
        """
        margin = clearance if clearance > 0 else PENETRATION

        def touch(a: int, b: int, *, link_a: int | None = None) -> bool:
            return bodies.in_contact(self.client, a, b, margin=margin, link_a=link_a)

        skip = set(ignore)
        held = self.held[0] if self.held else None
        obstacles = list(self.fixtures.values()) + [
            self.blocks[n] for n in self._placed if n not in skip and n != held
        ]
        for body in obstacles:
            if touch(self.robot, body):
                return True
        for link in self.arm_links:
            for base_link in self.base_links:
                pts = p.getClosestPoints(
                    self.robot,
                    self.robot,
                    distance=margin,
                    linkIndexA=link,
                    linkIndexB=base_link,
                    physicsClientId=self.client,
                )
                if pts:
                    return True
        if held is not None:
            body = self.blocks[held]
            for other in obstacles:
                if touch(body, other):
                    return True
            for base_link in self.base_links:
                if touch(self.robot, body, link_a=base_link):
                    return True
        return False

    def block_collides(self, name: str, *, margin: float) -> bool:
        """Block ``name`` (at its current pose) against the other placed blocks, with margin."""
        body = self.blocks[name]
        return any(
            bodies.in_contact(self.client, body, self.blocks[o], margin=margin)
            for o in self._placed
            if o != name
        )
