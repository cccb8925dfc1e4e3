"""The Panda tabletop in pybullet: the table, trays and shelves, the blocks and the arm, with the
collision queries the samplers, the motion planner and the validator ask."""

from __future__ import annotations

import logging
from collections.abc import Iterable, Sequence

from planner.domains.manipulation.world import PENETRATION, BlocksWorld, FixtureBox
from planner.domains.panda.geometry import PandaGeometry, Region
from planner.domains.panda.problem import ROBOT
from planner.domains.panda.values import Grasp
from planner.robots import get_robot
from planner.robots.panda.model import (
    ARM_JOINTS,
    BASE_LINK,
    FINGER_JOINTS,
    FINGER_OPEN,
    HAND_LINKS,
    TOOL_LINK,
    finger_joint,
)
from planner.sim import bodies
from planner.sim.collision import CollisionConfig, RobotCollision
from planner.sim.transforms import invert

log = logging.getLogger(__name__)

COLLISION = CollisionConfig()  # how the queries find their answer: broad phase, pair filter
TABLE_THICKNESS = 0.04  # the table top's slab below z = 0
# Links of the arm that can reach its base and first links (self-collision pairs worth checking):
# the forearm, wrist, hand and fingers against the base, shoulder and upper arm.
SELF_NEAR = ("panda_link0", "panda_link1", "panda_link2")
SELF_FAR = ("panda_link6", "panda_link7", *HAND_LINKS)
# A held block is checked against the arm's links up to the elbow (the hand holds it).
HELD_AGAINST = ("panda_link0", "panda_link1", "panda_link2", "panda_link3", "panda_link4")


def _fixtures(geometry: PandaGeometry) -> dict[str, FixtureBox]:
    """The table's slab and each tray's floor and rims, each shelf's box."""
    t = geometry.table
    out = {
        "table": (
            (t.size[0] / 2, t.size[1] / 2, TABLE_THICKNESS / 2),
            (t.center[0], t.center[1], -TABLE_THICKNESS / 2),
            t.color,
        )
    }
    for region in geometry.regions:
        for i, (half, center) in enumerate(fixture_boxes(region)):
            out[f"{region.name}#{i}"] = (half, center, region.color)
    return out


def fixture_boxes(
    region: Region,
) -> list[tuple[tuple[float, float, float], tuple[float, float, float]]]:
    """The boxes (half extents, centre) a region adds to the table: a tray's floor and four
    rims, a shelf's block from the table top to its surface; none for part of the table."""
    if region.kind == "table" or region.top <= 0:
        return []
    (cx, cy), (sx, sy), top = region.center, region.size, region.top
    w = region.wall
    boxes = [((sx / 2 + w, sy / 2 + w, top / 2), (cx, cy, top / 2))]
    if region.kind == "tray" and region.rim > 0 and w > 0:
        h = top + region.rim
        for dx, dy, hx, hy in (
            (-(sx + w) / 2, 0.0, w / 2, sy / 2 + w),
            ((sx + w) / 2, 0.0, w / 2, sy / 2 + w),
            (0.0, -(sy + w) / 2, sx / 2, w / 2),
            (0.0, (sy + w) / 2, sx / 2, w / 2),
        ):
            boxes.append(((hx, hy, h / 2), (cx + dx, cy + dy, h / 2)))
    return boxes


class PandaWorld(BlocksWorld[Grasp]):
    """One pybullet client holding a Panda tabletop; call :meth:`close` (or use ``with``)."""

    def __init__(self, geometry: PandaGeometry, *, collision: CollisionConfig = COLLISION) -> None:
        boxes = [
            (b.name, (b.size[0] / 2, b.size[1] / 2, b.size[2] / 2), b.color)
            for b in geometry.blocks
        ]
        super().__init__(get_robot(ROBOT), _fixtures(geometry), boxes, tool_link=TOOL_LINK)
        self.geometry = geometry
        c, joints, links = self.client, self.joints, self.links
        links[BASE_LINK] = -1
        self.arm_joints = [joints[n] for n in ARM_JOINTS]
        self.finger_joints = [joints[n] for n in FINGER_JOINTS]
        self.hand_links = [links[n] for n in HAND_LINKS]
        # Every link with a collision shape but the base, which stands on the table.
        self.moving_links = [links[n] for n in (*ARM_JOINTS_LINKS, *HAND_LINKS)]
        self.self_pairs = [(links[a], links[b]) for a in SELF_FAR for b in SELF_NEAR]
        self.held_against = [links[n] for n in HELD_AGAINST]
        self.set_fingers(FINGER_OPEN)
        self.collision = RobotCollision(c, self.robot, self_pairs=self.self_pairs, config=collision)
        self.hand_collision = RobotCollision(c, self.robot, links=self.hand_links, config=collision)

    # --- state -------------------------------------------------------------------------------

    def hold(self, block: str | None, grasp: Grasp | None = None, *, flip: bool = False) -> None:
        """Close the hand on a block (it then follows every :meth:`set_arm`), or open it."""
        self._obstacles.clear()
        if self.held is not None:  # the block let go of goes back where it stands, or away
            name = self.held[0]
            self._take(None, None)
            self._put(name)
        if block is None or grasp is None:
            self.set_fingers(FINGER_OPEN)
            return
        self._take((block, grasp), invert(grasp.tool_in_block(flip)))
        size = self.geometry.block(block).size
        self.set_fingers(
            finger_joint(size[1] if round(grasp.yaw / 1.5707963) % 2 == 0 else size[0])
        )
        self._update_held()

    def set_fingers(self, value: float) -> None:
        bodies.set_joints(self.client, self.robot, self.finger_joints, (value, value))

    def set_arm(self, arm: Sequence[float]) -> None:
        bodies.set_joints(self.client, self.robot, self.arm_joints, arm)
        self._update_held()

    # --- collisions --------------------------------------------------------------------------

    def robot_collides(self, *, ignore: Iterable[str] = (), clearance: float = 0.0) -> bool:
        """The arm (and what it holds) against the table, trays, shelves, placed blocks and
        itself. ``ignore`` names blocks the hand may touch (the one it closes on). Without
        ``clearance`` resting contact is allowed and only overlaps over 1 mm count."""
        # The arm's base stands on the table: only the links that move are checked there.
        obstacles = self.obstacles(ignore, links={"table": self.moving_links})
        return self._collides(self.collision, obstacles, clearance, self.held_against)

    def hand_collides(self, *, clearance: float = 0.0) -> bool:
        """The hand and fingers (and what they hold) against the fixtures and placed blocks:
        where the hand is set by the tool's pose alone, whatever the arm's joints."""
        return self._collides(self.hand_collision, self.obstacles(), clearance, ())

    def block_collides(self, name: str, *, margin: float) -> bool:
        """Block ``name`` (where it is) against the other placed blocks and the fixtures but the
        table (it stands on the table, a tray's floor or a shelf)."""
        rims = [b for k, b in self.fixtures.items() if k != "table"]
        return super().block_collides(name, margin=margin) or any(
            bodies.in_contact(self.client, self.blocks[name], r, margin=PENETRATION) for r in rims
        )


ARM_JOINTS_LINKS = tuple(f"panda_link{i}" for i in range(1, 8))
