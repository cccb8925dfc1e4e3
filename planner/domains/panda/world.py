"""The Panda tabletop in pybullet: the table, trays and shelves, the blocks and the arm, with the
collision queries the samplers, the motion planner and the validator ask."""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping, Sequence

import pybullet as p

from planner.domains.panda.geometry import PandaGeometry, Region, block_pose_to_pose
from planner.domains.panda.values import BlockPose, Grasp
from planner.robots.panda.model import (
    ARM_JOINTS,
    BASE_LINK,
    FINGER_JOINTS,
    FINGER_OPEN,
    HAND_LINKS,
    TOOL_LINK,
    finger_joint,
    urdf_path,
)
from planner.sim import bodies
from planner.sim.collision import Attached, CollisionConfig, Obstacles, RobotCollision
from planner.sim.transforms import Pose, invert, multiply

log = logging.getLogger(__name__)

PENETRATION = -0.001  # bodies overlapping by more than 1 mm collide; resting contact does not
COLLISION = CollisionConfig()  # how the queries find their answer: broad phase, pair filter
TABLE_THICKNESS = 0.04  # the table top's slab below z = 0
HIDDEN_Z = -10.0  # blocks not in the scene wait this far below the floor
# Links of the arm that can reach its base and first links (self-collision pairs worth checking):
# the forearm, wrist, hand and fingers against the base, shoulder and upper arm.
SELF_NEAR = ("panda_link0", "panda_link1", "panda_link2")
SELF_FAR = ("panda_link6", "panda_link7", *HAND_LINKS)
# A held block is checked against the arm's links up to the elbow (the hand holds it).
HELD_AGAINST = ("panda_link0", "panda_link1", "panda_link2", "panda_link3", "panda_link4")


def _fixtures(client: int, geometry: PandaGeometry) -> dict[str, int]:
    """The table's slab and each tray's floor and rims, each shelf's box, as static bodies."""
    t = geometry.table
    out = {
        "table": bodies.add_box(
            client,
            (t.size[0] / 2, t.size[1] / 2, TABLE_THICKNESS / 2),
            ((t.center[0], t.center[1], -TABLE_THICKNESS / 2), (0, 0, 0, 1)),
            t.color,
        )
    }
    for region in geometry.regions:
        for i, (half, center) in enumerate(fixture_boxes(region)):
            out[f"{region.name}#{i}"] = bodies.add_box(
                client, half, (center, (0, 0, 0, 1)), region.color
            )
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


class PandaWorld:
    """One pybullet client holding a Panda tabletop; call :meth:`close` (or use ``with``)."""

    def __init__(self, geometry: PandaGeometry, *, collision: CollisionConfig = COLLISION) -> None:
        self.geometry = geometry
        self.client = c = bodies.connect()
        self.fixtures = _fixtures(c, geometry)
        self.blocks: dict[str, int] = {}
        for i, block in enumerate(geometry.blocks):
            half = (block.size[0] / 2, block.size[1] / 2, block.size[2] / 2)
            self.blocks[block.name] = bodies.add_box(
                c, half, ((0, 0, HIDDEN_Z - i), (0, 0, 0, 1)), block.color
            )
        self.robot = int(
            p.loadURDF(
                str(urdf_path()),
                useFixedBase=True,
                flags=p.URDF_IGNORE_VISUAL_SHAPES,
                physicsClientId=c,
            )
        )
        joints = bodies.joint_indices(c, self.robot)
        links = bodies.link_indices(c, self.robot)
        links[BASE_LINK] = -1
        self.arm_joints = [joints[n] for n in ARM_JOINTS]
        self.finger_joints = [joints[n] for n in FINGER_JOINTS]
        self.tool_link = links[TOOL_LINK]
        self.hand_links = [links[n] for n in HAND_LINKS]
        # Every link with a collision shape but the base, which stands on the table.
        self.moving_links = [links[n] for n in (*ARM_JOINTS_LINKS, *HAND_LINKS)]
        self.self_pairs = [(links[a], links[b]) for a in SELF_FAR for b in SELF_NEAR]
        self.held_against = [links[n] for n in HELD_AGAINST]
        self.held: tuple[str, Grasp, Pose] | None = None  # block, grasp, block in the tool frame
        self.placed: dict[str, BlockPose] = {}
        self.set_fingers(FINGER_OPEN)
        self.collision = RobotCollision(c, self.robot, self_pairs=self.self_pairs, config=collision)
        self.hand_collision = RobotCollision(c, self.robot, links=self.hand_links, config=collision)
        # The obstacles (with their boxes) per held block, ignored blocks and checker; forgotten
        # whenever a block may have moved (set_blocks, hold).
        self._obstacles: dict[tuple[str | None, frozenset[str], bool], Obstacles] = {}

    def __enter__(self) -> PandaWorld:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        bodies.disconnect(self.client)

    # --- state -------------------------------------------------------------------------------

    def set_blocks(self, poses: Mapping[str, BlockPose]) -> None:
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
            z = HIDDEN_Z - list(self.blocks).index(name)
            bodies.set_pose(self.client, self.blocks[name], ((0, 0, z), (0, 0, 0, 1)))

    def hold(self, block: str | None, grasp: Grasp | None = None, *, flip: bool = False) -> None:
        """Close the hand on a block (it then follows every :meth:`set_arm`), or open it."""
        self._obstacles.clear()
        if self.held is not None:  # the block let go of goes back where it stands, or away
            name = self.held[0]
            self.held = None
            self._put(name)
        if block is None or grasp is None:
            self.set_fingers(FINGER_OPEN)
            return
        self.held = (block, grasp, invert(grasp.tool_in_block(flip)))
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

    def tool_pose(self) -> Pose:
        return bodies.link_pose(self.client, self.robot, self.tool_link)

    def _update_held(self) -> None:
        if self.held is None:
            return
        name, _, block_in_tool = self.held
        bodies.set_pose(self.client, self.blocks[name], multiply(self.tool_pose(), block_in_tool))

    def held_pose(self) -> Pose | None:
        if self.held is None:
            return None
        return bodies.get_pose(self.client, self.blocks[self.held[0]])

    # --- collisions --------------------------------------------------------------------------

    def obstacles(self, ignore: Iterable[str] = ()) -> list[int]:
        """The fixtures and the placed blocks but those in ``ignore`` and the held one."""
        skip = set(ignore)
        if self.held is not None:
            skip.add(self.held[0])
        return [*self.fixtures.values(), *(self.blocks[n] for n in self.placed if n not in skip)]

    def _obstacle_set(self, ignore: Iterable[str], *, hand: bool) -> Obstacles:
        held = self.held[0] if self.held is not None else None
        key = (held, frozenset(ignore), hand)
        found = self._obstacles.get(key)
        if found is None:
            table = self.fixtures["table"]
            # The arm's base stands on the table: only the links that move are checked there.
            links = None if hand else {table: self.moving_links}
            found = Obstacles(self.client, self.obstacles(ignore), links=links)
            self._obstacles[key] = found
        return found

    def robot_collides(self, *, ignore: Iterable[str] = (), clearance: float = 0.0) -> bool:
        """The arm (and what it holds) against the table, trays, shelves, placed blocks and
        itself. ``ignore`` names blocks the hand may touch (the one it closes on). Without
        ``clearance`` resting contact is allowed and only overlaps over 1 mm count."""
        held = self.blocks[self.held[0]] if self.held is not None else None
        return self.collision.collides(
            self._obstacle_set(ignore, hand=False),
            margin=clearance if clearance > 0 else PENETRATION,
            attached=None if held is None else Attached(held, tuple(self.held_against)),
        )

    def hand_collides(self, *, clearance: float = 0.0) -> bool:
        """The hand and fingers (and what they hold) against the fixtures and placed blocks:
        where the hand is set by the tool's pose alone, whatever the arm's joints."""
        held = self.blocks[self.held[0]] if self.held is not None else None
        return self.hand_collision.collides(
            self._obstacle_set((), hand=True),
            margin=clearance if clearance > 0 else PENETRATION,
            attached=None if held is None else Attached(held, ()),
        )

    def block_collides(self, name: str, *, margin: float) -> bool:
        """Block ``name`` (where it is) against the other placed blocks and the fixtures but the
        table (it stands on the table, a tray's floor or a shelf)."""
        body = self.blocks[name]
        others = [self.blocks[o] for o in self.placed if o != name]
        rims = [b for k, b in self.fixtures.items() if k != "table"]
        return any(bodies.in_contact(self.client, body, o, margin=margin) for o in others) or any(
            bodies.in_contact(self.client, body, r, margin=PENETRATION) for r in rims
        )


ARM_JOINTS_LINKS = tuple(f"panda_link{i}" for i in range(1, 8))
