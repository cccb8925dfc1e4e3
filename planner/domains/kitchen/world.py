"""The kitchen in pybullet: fixtures, blocks and the generated PR2, with collision queries."""

from __future__ import annotations

import logging
from collections.abc import Iterable

import pybullet as p

from planner.domains.kitchen.geometry import KitchenGeometry
from planner.domains.kitchen.problem import ROBOT
from planner.domains.kitchen.values import Conf, Grasp
from planner.domains.manipulation.world import BlocksWorld
from planner.robots import get_robot
from planner.robots.pr2.dimensions import BASE_LINK
from planner.robots.pr2.model import (
    ARM_JOINTS,
    ARM_LINKS,
    ARMS,
    GRIPPER_LINKS,
    REST_ARM_CONF,
    TOOL_LINK,
    TORSO_JOINT,
)
from planner.sim import bodies
from planner.sim.collision import CollisionConfig, RobotCollision
from planner.sim.transforms import invert, planar_pose

log = logging.getLogger(__name__)

COLLISION = CollisionConfig()  # how robot_collides finds its answer: broad phase, pair filter


class KitchenWorld(BlocksWorld[Grasp]):
    """One pybullet client holding a kitchen scene; call :meth:`close` (or use ``with``).

    ``collision`` sets how :meth:`robot_collides` finds its answer (the answer is the same).
    """

    def __init__(
        self, geometry: KitchenGeometry, arm: str, *, collision: CollisionConfig = COLLISION
    ) -> None:
        fixtures = {
            plat.name: (
                (plat.size[0] / 2, plat.size[1] / 2, plat.size[2] / 2),
                (plat.center[0], plat.center[1], plat.size[2] / 2),
                plat.color,
            )
            for plat in geometry.platforms
        }
        cubes = [(b.name, (b.size / 2, b.size / 2, b.size / 2), b.color) for b in geometry.blocks]
        super().__init__(get_robot(ROBOT), fixtures, cubes, tool_link=TOOL_LINK[arm])
        self.geometry = geometry
        self.arm = arm
        c, joints, links = self.client, self.joints, self.links
        self.arm_joints = [joints[n] for n in ARM_JOINTS[arm]]
        self.torso_joint = joints[TORSO_JOINT]
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
        # The gripper alone (rigid below the wrist: where it is follows from the tool's pose,
        # whatever the base and the arm), for what no IK solution can avoid.
        self.gripper_collision = RobotCollision(
            c, self.robot, links=[links[n] for n in GRIPPER_LINKS[arm]], config=collision
        )
        # What pybullet holds now, so that a set_* call only resets what changed (a base move
        # leaves the joints alone, an arm move the base): None until first set.
        self._base: tuple[float, float, float] | None = None
        self._torso: float | None = None
        self._arm: tuple[float, ...] | None = None

    # --- state -------------------------------------------------------------------------------

    def hold(self, block: str | None, grasp: Grasp | None = None) -> None:
        """Attach a block to the gripper (it then follows every :meth:`set_conf`)."""
        held = None if block is None or grasp is None else (block, grasp)
        if (None if held is None else held[0]) != (None if self.held is None else self.held[0]):
            self._obstacles.clear()  # a block let go of stays where the hand left it
        self._take(held, None if held is None else invert(held[1].tool_in_block))

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

    # --- collisions --------------------------------------------------------------------------

    def robot_collides(self, *, ignore: Iterable[str] = (), clearance: float = 0.0) -> bool:
        """The robot (and what it holds) against fixtures, placed blocks and its own base.

        ``ignore`` names blocks the gripper may touch (the one it is about to grasp). Without
        ``clearance`` resting contact is allowed and only overlaps over 1 mm count; planners ask
        for a clearance so that what they plan between checked states stays free too.
        """
        return self._collides(self.collision, self.obstacles(ignore), clearance, self._base_links)

    def gripper_collides(self, *, ignore: Iterable[str] = (), clearance: float = 0.0) -> bool:
        """The gripper and what it holds against fixtures and placed blocks, as
        :meth:`robot_collides` checks them (so True here means True there): a collision every
        configuration with the tool where it is now has, from any base pose."""
        return self._collides(self.gripper_collision, self.obstacles(ignore), clearance, ())
