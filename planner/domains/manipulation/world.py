"""The pybullet world of a manipulation domain: fixture boxes, blocks and one robot (from the
registry, :mod:`planner.robots`), a block held in the robot's hand, and collision queries whose
obstacles are read once and kept until a block may move.

A domain's world subclasses :class:`BlocksWorld`, adding how its robot is set (a mobile base and
torso, or an arm and fingers), how its hand takes and lets go of a block, and which links are
checked against what.
"""

from __future__ import annotations

from collections.abc import Hashable, Iterable, Mapping, Sequence
from typing import Generic, Self, TypeVar

import pybullet as p

from planner.domains.manipulation.problem import UprightPose, block_pose_to_pose
from planner.robots import Robot
from planner.sim import bodies
from planner.sim.collision import Attached, Obstacles, RobotCollision
from planner.sim.transforms import Pose, Vec3, multiply

PENETRATION = -0.001  # bodies overlapping by more than 1 mm collide; resting contact does not
HIDDEN_Z = -10.0  # blocks not in the scene wait this far below the floor (one apart each)
UPRIGHT = (0.0, 0.0, 0.0, 1.0)
FixtureBox = tuple[Vec3, Vec3, bodies.Color]  # half extents, centre, colour
G = TypeVar("G")  # how the hand holds a block (a domain's grasp)


class BlocksWorld(Generic[G]):
    """One pybullet client holding fixture boxes, blocks and ``robot``; call :meth:`close` (or
    use ``with``).

    ``fixtures``: name -> box, standing still. ``blocks``: name, half extents and colour of each
    block, out of the way until :meth:`set_blocks` puts it somewhere. The robot is loaded from
    its URDF without visual shapes (the planner's world never draws: it loads in 20 ms instead
    of 0.4 s for the first world of a process, which parses each mesh file) on a fixed base
    at the origin; ``tool_link`` is the link a held block rides with.
    """

    def __init__(
        self,
        robot: Robot,
        fixtures: Mapping[str, FixtureBox],
        blocks: Sequence[tuple[str, Vec3, bodies.Color]],
        *,
        tool_link: str,
    ) -> None:
        self.client = c = bodies.connect()
        self.fixtures = {
            name: bodies.add_box(c, half, (centre, UPRIGHT), color)
            for name, (half, centre, color) in fixtures.items()
        }
        self.blocks: dict[str, int] = {}
        for i, (name, half, color) in enumerate(blocks):
            self.blocks[name] = bodies.add_box(c, half, _hidden(i), color)
        self.robot = int(
            p.loadURDF(
                str(robot.urdf()),
                useFixedBase=True,
                flags=p.URDF_IGNORE_VISUAL_SHAPES,
                physicsClientId=c,
            )
        )
        self.joints = bodies.joint_indices(c, self.robot)
        self.links = bodies.link_indices(c, self.robot)
        self.tool_link = self.links[tool_link]
        self.held: tuple[str, G] | None = None  # the block in the hand and how it is held
        self._in_tool: Pose | None = None  # the held block in the tool frame
        self.placed: dict[str, UprightPose] = {}  # blocks standing somewhere
        # The obstacles the collision queries check, with their boxes, per what is held and
        # ignored; forgotten whenever a block may have moved.
        self._obstacles: dict[Hashable, Obstacles] = {}

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        bodies.disconnect(self.client)

    # --- state -------------------------------------------------------------------------------

    def set_blocks(self, poses: Mapping[str, UprightPose]) -> None:
        """Put the given blocks at their poses and every other block (but the held one) away."""
        self.placed = dict(poses)
        self._obstacles.clear()
        held = self.held[0] if self.held else None
        for name in self.blocks:
            if name != held or name in poses:
                self._put(name)

    def _put(self, name: str) -> None:
        """Block ``name`` at its placed pose, else out of the way."""
        pose = self.placed.get(name)
        if pose is not None:
            bodies.set_pose(self.client, self.blocks[name], block_pose_to_pose(pose))
        else:
            bodies.set_pose(self.client, self.blocks[name], _hidden(list(self.blocks).index(name)))

    def hold(self, block: str | None, grasp: G | None = None) -> None:
        """Take ``block`` into the hand by ``grasp`` (it then follows the robot), or let go: the
        domain's world knows its hand."""
        raise NotImplementedError

    def _take(self, held: tuple[str, G] | None, in_tool: Pose | None) -> None:
        """What the hand holds from now on, and where in the tool frame."""
        self.held = held
        self._in_tool = None if held is None else in_tool

    def tool_pose(self) -> Pose:
        return bodies.link_pose(self.client, self.robot, self.tool_link)

    def _update_held(self) -> None:
        """The held block to where the hand holds it now."""
        if self.held is None or self._in_tool is None:
            return
        pose = multiply(self.tool_pose(), self._in_tool)
        bodies.set_pose(self.client, self.blocks[self.held[0]], pose)

    # --- collisions --------------------------------------------------------------------------

    def obstacles(
        self, ignore: Iterable[str] = (), *, links: Mapping[str, Sequence[int]] | None = None
    ) -> Obstacles:
        """The fixtures and the placed blocks but those in ``ignore`` and the held one, with
        their boxes; kept until a block may move. ``links`` narrows the robot links checked
        against some fixtures (by name: the table a fixed arm stands on)."""
        held = self.held[0] if self.held is not None else None
        skip = frozenset(ignore)
        key = (held, skip, links is None)
        found = self._obstacles.get(key)
        if found is None:
            members = [
                *self.fixtures.values(),
                *(self.blocks[n] for n in self.placed if n not in skip and n != held),
            ]
            only = None if links is None else {self.fixtures[k]: v for k, v in links.items()}
            found = self._obstacles[key] = Obstacles(self.client, members, links=only)
        return found

    def _collides(
        self,
        checker: RobotCollision,
        obstacles: Obstacles,
        clearance: float,
        held_against: Sequence[int],
    ) -> bool:
        """``checker``'s answer (the robot, or some of its links, and the held block checked
        against ``held_against`` too): without ``clearance`` resting contact is allowed and only
        overlaps over 1 mm count."""
        held = self.held
        return checker.collides(
            obstacles,
            margin=clearance if clearance > 0 else PENETRATION,
            attached=None if held is None else Attached(self.blocks[held[0]], tuple(held_against)),
        )

    def block_collides(self, name: str, *, margin: float) -> bool:
        """Block ``name`` (where it is) within ``margin`` of another placed block; a domain's
        world may check it against more."""
        body = self.blocks[name]
        return any(
            bodies.in_contact(self.client, body, self.blocks[o], margin=margin)
            for o in self.placed
            if o != name
        )


def _hidden(i: int) -> Pose:
    """Where the ``i``-th block waits while it is not in the scene."""
    return ((0.0, 0.0, HIDDEN_Z - i), UPRIGHT)
