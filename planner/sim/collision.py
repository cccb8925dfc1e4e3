"""Does a robot, and what it carries, come within a margin of anything? With a broad phase.

:class:`RobotCollision` answers the question a motion planner's validity checker asks, for any
robot loaded in pybullet (on a mobile base or a fixed one): its links against obstacle bodies,
chosen pairs of its own links against each other, and an optional attached body (a held block)
against the obstacles and chosen robot links. The answer is pybullet's exact one (some
``getClosestPoints`` query within the margin reports a point); it is found with fewer queries:

- **broad phase** (``CollisionConfig.broad_phase``): an exact query is only made for a pair
  whose axis-aligned boxes, grown by the margin (and ``slack``), overlap. The obstacles' boxes
  are read once (:class:`Obstacles`) and grouped into clusters whose grown boxes overlap (a
  table and the blocks on it); one ``getOverlappingObjects`` call per cluster finds the robot
  links whose boxes are near (pybullet keeps them current as the base and joints are reset).
  Self pairs take one such call per hub link, the attached body one. A pair skipped is a pair
  whose shapes are farther apart than the margin, so the answer does not change.
- **pair filter** (``CollisionConfig.pair_filter``): self pairs that no joint values can bring
  within the margin are dropped, by geometry (:meth:`RobotCollision.pair_bound`), and so are
  pairs with a link that has no collision shape (pybullet reports nothing for it).

``CollisionConfig(broad_phase=False, pair_filter=False)`` makes every exact query there is: the
reference the tests compare against. The physics client id is passed explicitly; nothing here
knows any particular robot or domain.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import pybullet as p

from planner.sim.transforms import Vec3

log = logging.getLogger(__name__)

Box = tuple[Vec3, Vec3]  # axis-aligned box: (min corner, max corner)
LinkPair = tuple[int, int]  # two link indices of the robot (-1: its base)
_EVERYWHERE: Box = ((-math.inf, -math.inf, -math.inf), (math.inf, math.inf, math.inf))


@dataclass(frozen=True)
class CollisionConfig:
    """How :class:`RobotCollision` finds its answer (the answer is the same either way)."""

    # Exact queries only for pairs whose boxes, grown by the margin, overlap (same answers).
    broad_phase: bool = True
    # Drop self pairs that no joint values bring within the margin, and shapeless links.
    pair_filter: bool = True
    # Metres added to the margin when growing boxes, against rounding in pybullet's distances.
    slack: float = 1e-3

    def __post_init__(self) -> None:
        if not self.slack >= 0:
            raise ValueError("slack must be >= 0")


@dataclass(frozen=True)
class Attached:
    """A body the robot carries (a held block), placed by the caller wherever the hand is.

    It is checked against every obstacle and against the robot's ``links`` (not the hand that
    holds it, which it touches).
    """

    body: int
    links: tuple[int, ...] = ()


class Obstacles:
    """Obstacle bodies with their boxes as they stand now, read once.

    Pass it to :meth:`RobotCollision.collides` for as long as none of the bodies moves, and
    make a new one when one does (a plain list of bodies is read afresh at every query).
    ``links`` narrows the robot links checked against some of the bodies (the table a fixed
    arm's base stands on: the links that move); the others meet the checker's ``links``. For the
    broad phase the bodies are grouped, per margin, into clusters whose grown boxes overlap (the
    blocks standing on a table and the table): one box query per cluster finds the robot links
    near any of them, and only a link found near a cluster of several is measured against
    each member's box.
    """

    def __init__(
        self,
        client: int,
        bodies: Iterable[int],
        *,
        links: Mapping[int, Iterable[int]] | None = None,
    ) -> None:
        self.client = client
        self.bodies = tuple(bodies)
        self.members = frozenset(self.bodies)
        self.links = {body: frozenset(only) for body, only in (links or {}).items()}
        self.boxes = {body: body_box(client, body) for body in self.bodies}
        self._clusters: dict[float, tuple[_Cluster, ...]] = {}

    def clusters(self, grow: float) -> tuple[_Cluster, ...]:
        """The bodies grouped by overlap of their boxes grown by ``grow``."""
        found = self._clusters.get(grow)
        if found is None:
            found = self._clusters[grow] = _cluster(
                [(body, _grown(self.boxes[body], grow)) for body in self.bodies]
            )
        return found


@dataclass(frozen=True)
class _Cluster:
    """Obstacles whose grown boxes overlap, and the box around them all."""

    box: Box
    members: tuple[tuple[int, Box], ...]  # body, grown box


def body_box(client: int, body: int) -> Box:
    """The box around every collision shape of ``body``, all its links."""
    n = p.getNumJoints(body, physicsClientId=client)
    if n == 0:
        return _floats(p.getAABB(body, physicsClientId=client))
    boxes = [_floats(p.getAABB(body, link, physicsClientId=client)) for link in range(-1, n)]
    return (
        (min(b[0][0] for b in boxes), min(b[0][1] for b in boxes), min(b[0][2] for b in boxes)),
        (max(b[1][0] for b in boxes), max(b[1][1] for b in boxes), max(b[1][2] for b in boxes)),
    )


def _floats(box: Any) -> Box:
    """pybullet's box as floats."""
    (x0, y0, z0), (x1, y1, z1) = box
    return (float(x0), float(y0), float(z0)), (float(x1), float(y1), float(z1))


def _grown(box: Box, grow: float) -> Box:
    (x0, y0, z0), (x1, y1, z1) = box
    return (x0 - grow, y0 - grow, z0 - grow), (x1 + grow, y1 + grow, z1 + grow)


def _overlap(a: Box, b: Box) -> bool:
    (ax0, ay0, az0), (ax1, ay1, az1) = a
    (bx0, by0, bz0), (bx1, by1, bz1) = b
    return ax0 <= bx1 and bx0 <= ax1 and ay0 <= by1 and by0 <= ay1 and az0 <= bz1 and bz0 <= az1


def _cluster(boxes: list[tuple[int, Box]]) -> tuple[_Cluster, ...]:
    """Connected groups of overlapping boxes, in the order of their first member."""
    root = list(range(len(boxes)))

    def find(i: int) -> int:
        while root[i] != i:
            i = root[i]
        return i

    for i in range(len(boxes)):
        for j in range(i):
            if _overlap(boxes[i][1], boxes[j][1]):
                a, b = find(i), find(j)
                root[max(a, b)] = min(a, b)
    groups: dict[int, list[tuple[int, Box]]] = {}
    for i, item in enumerate(boxes):
        groups.setdefault(find(i), []).append(item)
    out = []
    for members in groups.values():
        lo = tuple(min(box[0][i] for _, box in members) for i in range(3))
        hi = tuple(max(box[1][i] for _, box in members) for i in range(3))
        out.append(_Cluster(((lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2])), tuple(members)))
    return tuple(out)


@dataclass(frozen=True)
class _Chain:
    """Where a link's collision shapes can be, over all joint values, relative to an ancestor:
    within ``radius`` of some point of ``region`` (a box in world coordinates, as placed when
    the checker was built)."""

    region: Box
    radius: float


class RobotCollision:
    """Collision queries for one robot body in one pybullet client.

    ``links``: the robot links checked against obstacles (default: all of them).
    ``self_pairs``: pairs of robot links worth checking against each other, e.g. an arm's
    links against the base it is mounted on; pairs of neighbouring links that always touch do
    not belong here. Build the checker after the robot is loaded; the joint values it is built
    at do not matter.
    """

    def __init__(
        self,
        client: int,
        robot: int,
        *,
        links: Sequence[int] | None = None,
        self_pairs: Iterable[LinkPair] = (),
        config: CollisionConfig = CollisionConfig(),
    ) -> None:
        self.client = client
        self.robot = robot
        self.config = config
        n = p.getNumJoints(robot, physicsClientId=client)
        infos = [p.getJointInfo(robot, j, physicsClientId=client) for j in range(n)]
        self._parent = {j: int(infos[j][16]) for j in range(n)}
        self._joint_type = {j: int(infos[j][2]) for j in range(n)}
        self._limits = {j: (float(infos[j][8]), float(infos[j][9])) for j in range(n)}
        self.shaped = frozenset(
            link
            for link in range(-1, n)
            if p.getCollisionShapeData(robot, link, physicsClientId=client)
        )
        self.links: tuple[int, ...] | None = None if links is None else tuple(links)
        self._link_set = None if links is None else frozenset(links)
        self.self_pairs: tuple[LinkPair, ...] = tuple((a, b) for a, b in self_pairs)
        for a, b in self.self_pairs:
            if a == b or not (-1 <= a < n and -1 <= b < n):
                raise ValueError(f"self pair ({a}, {b}) is not two links of the robot")
        self._bounds = self._pair_bounds() if config.pair_filter else {}
        self._plans: dict[float, _SelfPlan] = {}  # per margin: which self pairs, how queried

    # --- the query ---------------------------------------------------------------------------

    def collides(
        self,
        obstacles: Obstacles | Sequence[int],
        *,
        margin: float,
        attached: Attached | None = None,
    ) -> bool:
        """True when the robot (its ``links``), a self pair or the attached body comes closer
        than ``margin`` metres to something: exactly when some ``getClosestPoints`` query
        within ``margin`` between them reports a point. A negative margin asks for overlaps
        deeper than ``-margin``."""
        if not isinstance(obstacles, Obstacles):
            obstacles = Obstacles(self.client, obstacles)
        if not self.config.broad_phase:
            return (
                self._obstacles_exact(obstacles, margin)
                or self._self_collides(margin)
                or (attached is not None and self._attached_exact(attached, obstacles, margin))
            )
        grow = max(margin, 0.0) + self.config.slack
        return (
            self._obstacles_broad(obstacles, margin, grow)
            or self._self_collides(margin)
            or (attached is not None and self._attached_broad(attached, obstacles, margin, grow))
        )

    def kept_pairs(self, margin: float) -> tuple[LinkPair, ...]:
        """The self pairs checked at ``margin`` (all of them without the pair filter)."""
        return self._plan(margin).pairs

    # --- robot against obstacles -------------------------------------------------------------

    def _obstacles_exact(self, obstacles: Obstacles, margin: float) -> bool:
        c, robot = self.client, self.robot
        for body in obstacles.bodies:
            links = obstacles.links.get(body, self.links)
            if links is None:
                if p.getClosestPoints(robot, body, margin, physicsClientId=c):
                    return True
                continue
            for link in links:
                if p.getClosestPoints(robot, body, margin, linkIndexA=link, physicsClientId=c):
                    return True
        return False

    def _obstacles_broad(self, obstacles: Obstacles, margin: float, grow: float) -> bool:
        c, robot, links, only = self.client, self.robot, self._link_set, obstacles.links
        for cluster in obstacles.clusters(grow):
            near = p.getOverlappingObjects(cluster.box[0], cluster.box[1], physicsClientId=c)
            if not near:
                continue
            for other, link in near:
                if other != robot:
                    continue
                if len(cluster.members) == 1:
                    body = cluster.members[0][0]
                    allowed = only.get(body, links)
                    if (allowed is None or link in allowed) and p.getClosestPoints(
                        robot, body, margin, linkIndexA=link, physicsClientId=c
                    ):
                        return True
                    continue
                box = p.getAABB(robot, link, physicsClientId=c)
                for body, grown in cluster.members:
                    allowed = only.get(body, links)
                    if (
                        (allowed is None or link in allowed)
                        and _overlap(box, grown)
                        and p.getClosestPoints(
                            robot, body, margin, linkIndexA=link, physicsClientId=c
                        )
                    ):
                        return True
        return False

    # --- self pairs --------------------------------------------------------------------------

    def _self_collides(self, margin: float) -> bool:
        plan = self._plan(margin)
        c, robot = self.client, self.robot
        if not self.config.broad_phase:
            return any(
                p.getClosestPoints(
                    robot, robot, margin, linkIndexA=a, linkIndexB=b, physicsClientId=c
                )
                for a, b in plan.pairs
            )
        grow = max(margin, 0.0) + self.config.slack
        for hub, others in plan.hubs:
            box = _grown(p.getAABB(robot, hub, physicsClientId=c), grow)
            near = p.getOverlappingObjects(box[0], box[1], physicsClientId=c)
            if not near:
                continue
            for other, link in near:
                if (
                    other == robot
                    and link in others
                    and p.getClosestPoints(
                        robot, robot, margin, linkIndexA=link, linkIndexB=hub, physicsClientId=c
                    )
                ):
                    return True
        return False

    def _plan(self, margin: float) -> _SelfPlan:
        plan = self._plans.get(margin)
        if plan is None:
            if self.config.pair_filter:
                pairs = tuple(pair for pair in self.self_pairs if self._bounds[pair] <= margin)
            else:
                pairs = self.self_pairs
            plan = _SelfPlan(pairs, _hubs(pairs))
            self._plans[margin] = plan
            if self.config.pair_filter:
                log.debug(
                    "margin %g: %d of %d self pairs can come that close",
                    margin,
                    len(pairs),
                    len(self.self_pairs),
                )
        return plan

    # --- the attached body -------------------------------------------------------------------

    def _attached_exact(self, attached: Attached, obstacles: Obstacles, margin: float) -> bool:
        c = self.client
        if any(
            p.getClosestPoints(attached.body, body, margin, physicsClientId=c)
            for body in obstacles.bodies
        ):
            return True
        return any(
            p.getClosestPoints(
                self.robot, attached.body, margin, linkIndexA=link, physicsClientId=c
            )
            for link in attached.links
        )

    def _attached_broad(
        self, attached: Attached, obstacles: Obstacles, margin: float, grow: float
    ) -> bool:
        c, robot, body = self.client, self.robot, attached.body
        box = _grown(body_box(c, body), grow)
        near = p.getOverlappingObjects(box[0], box[1], physicsClientId=c)
        if not near:
            return False
        for other, link in near:
            if other == robot:
                if link in attached.links and p.getClosestPoints(
                    robot, body, margin, linkIndexA=link, physicsClientId=c
                ):
                    return True
            elif other in obstacles.members and p.getClosestPoints(
                body, other, margin, physicsClientId=c
            ):
                return True
        return False

    # --- which self pairs can touch ----------------------------------------------------------

    def pair_bound(self, a: int, b: int) -> float:
        """A lower bound on the distance between links ``a`` and ``b`` over all joint values
        (``inf`` when either has no collision shape); the pair filter drops a pair whose bound
        exceeds the margin.

        By geometry, not sampling: below the links' lowest common ancestor ``c``, every link
        hangs from a chain of joints. Until the chain's first revolute joint, nothing turns
        relative to ``c``: fixed joints carry the link rigidly, prismatic ones sweep it along a
        segment (the joint's travel between its limits), so the first revolute joint's origin
        lies in a box fixed to ``c``. From there on, each joint origin is a fixed distance from
        the one before (plus its travel for a prismatic joint) whatever the angles, and the
        link's shapes lie within their bounding box's farthest corner of its frame. So the link
        stays within a radius of the box; the bound is the gap between the two links' boxes
        (or the ancestor's own bounding box, when one link is the ancestor of the other) less
        the radii. Spherical joints count as revolute, planar ones as unbounded.
        """
        if a not in self.shaped or b not in self.shaped:
            return math.inf
        c = self._common_ancestor(a, b)
        if c == b:
            reach = self._chain(b, a)
            return _box_gap(reach.region, self._aabb(b)) - reach.radius
        if c == a:
            reach = self._chain(a, b)
            return _box_gap(reach.region, self._aabb(a)) - reach.radius
        ra, rb = self._chain(c, a), self._chain(c, b)
        return _box_gap(ra.region, rb.region) - ra.radius - rb.radius

    def _pair_bounds(self) -> dict[LinkPair, float]:
        return {pair: self.pair_bound(*pair) for pair in self.self_pairs}

    def _chain(self, ancestor: int, link: int) -> _Chain:
        """Where ``link`` can be relative to ``ancestor`` (see :meth:`pair_bound`)."""
        path: list[int] = []  # joints from the ancestor down to the link
        j = link
        while j != ancestor:
            path.append(j)
            j = self._parent[j]
        path.reverse()
        anchor = link  # the first revolute joint's child link, else the link itself
        sweeps: list[Box] = []
        radius = 0.0
        turned = False
        previous = -2  # no joint origin yet
        for j in path:
            kind = self._joint_type[j]
            if kind not in (p.JOINT_FIXED, p.JOINT_PRISMATIC, p.JOINT_REVOLUTE, p.JOINT_SPHERICAL):
                return _Chain(_EVERYWHERE, math.inf)  # planar: anywhere
            if not turned:
                if kind == p.JOINT_PRISMATIC:
                    sweeps.append(self._sweep(j))
                elif kind != p.JOINT_FIXED:
                    turned = True
                    anchor = j
                    previous = j
                continue
            radius += _dist(self._origin(j), self._origin(previous))
            if kind == p.JOINT_PRISMATIC:
                lo, hi = self._sweep(j)
                radius += _dist(lo, hi)
            previous = j
        centre = self._origin(anchor)
        lo_x, lo_y, lo_z = centre
        hi_x, hi_y, hi_z = centre
        for (ax, ay, az), (bx, by, bz) in sweeps:
            lo_x, lo_y, lo_z = lo_x + min(ax, bx), lo_y + min(ay, by), lo_z + min(az, bz)
            hi_x, hi_y, hi_z = hi_x + max(ax, bx), hi_y + max(ay, by), hi_z + max(az, bz)
        radius += self._shape_radius(link)
        return _Chain(((lo_x, lo_y, lo_z), (hi_x, hi_y, hi_z)), radius)

    def _sweep(self, joint: int) -> Box:
        """How far the prismatic ``joint`` can move its child from where it is: the displacement
        at its lower and upper limits (a "box" of two corner points, not ordered)."""
        lo, hi = self._limits[joint]
        if lo > hi:  # no limits
            return _EVERYWHERE
        c, robot = self.client, self.robot
        q = float(p.getJointState(robot, joint, physicsClientId=c)[0])
        here = self._origin(joint)
        ends = []
        for value in (lo, hi):
            p.resetJointState(robot, joint, value, physicsClientId=c)
            end = self._origin(joint)
            ends.append((end[0] - here[0], end[1] - here[1], end[2] - here[2]))
        p.resetJointState(robot, joint, q, physicsClientId=c)
        return ends[0], ends[1]

    def _origin(self, link: int) -> Vec3:
        """A point fixed to ``link``: its URDF frame's origin (the base's inertial frame's)."""
        if link == -1:
            pos = p.getBasePositionAndOrientation(self.robot, physicsClientId=self.client)[0]
        else:
            pos = p.getLinkState(
                self.robot, link, computeForwardKinematics=True, physicsClientId=self.client
            )[4]
        return (float(pos[0]), float(pos[1]), float(pos[2]))

    def _shape_radius(self, link: int) -> float:
        """How far ``link``'s collision shapes reach from :meth:`_origin`: to the farthest
        corner of their bounding box."""
        (x0, y0, z0), (x1, y1, z1) = self._aabb(link)
        o = self._origin(link)
        return math.sqrt(
            max((x0 - o[0]) ** 2, (x1 - o[0]) ** 2)
            + max((y0 - o[1]) ** 2, (y1 - o[1]) ** 2)
            + max((z0 - o[2]) ** 2, (z1 - o[2]) ** 2)
        )

    def _aabb(self, link: int) -> Box:
        return _floats(p.getAABB(self.robot, link, physicsClientId=self.client))

    def _common_ancestor(self, a: int, b: int) -> int:
        above = {a}
        while a != -1:
            a = self._parent[a]
            above.add(a)
        while b not in above:
            b = self._parent[b]
        return b


@dataclass(frozen=True)
class _SelfPlan:
    """The self pairs checked at one margin, grouped for the broad phase: one box query per hub
    link finds which of its partners are near."""

    pairs: tuple[LinkPair, ...]
    hubs: tuple[tuple[int, frozenset[int]], ...]


def _hubs(pairs: Sequence[LinkPair]) -> tuple[tuple[int, frozenset[int]], ...]:
    """Cover the pairs with few hub links: repeatedly the link in most of the pairs left."""
    left = list(pairs)
    hubs: list[tuple[int, frozenset[int]]] = []
    while left:
        counts: dict[int, int] = {}
        for a, b in left:
            counts[a] = counts.get(a, 0) + 1
            counts[b] = counts.get(b, 0) + 1
        hub = max(counts, key=lambda link: (counts[link], -link))
        hubs.append((hub, frozenset(b if a == hub else a for a, b in left if hub in (a, b))))
        left = [(a, b) for a, b in left if hub not in (a, b)]
    return tuple(hubs)


def _dist(a: Vec3, b: Vec3) -> float:
    return math.sqrt((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2)


def _box_gap(a: Box, b: Box) -> float:
    """Euclidean distance between two axis-aligned boxes (0 when they overlap)."""
    total = 0.0
    for i in range(3):
        gap = max(b[0][i] - a[1][i], a[0][i] - b[1][i], 0.0)
        total += gap * gap
    return math.sqrt(total)
