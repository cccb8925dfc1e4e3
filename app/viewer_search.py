"""A run's search tree folded from its events into what the 3D view draws (no viser here).

:class:`SearchFold` takes event dicts exactly as :func:`planner.events.event_to_dict` makes them,
one at a time, and keeps the tree's shape, each node's predicted cost ``Q`` and, for the kitchen,
where each sampled value lies in the world: a placement is a block pose, a grasp is a gripper
pose at the block's initial pose, an IK result is a base pose on the floor, a motion is the path
of the base. A failed query is kept with the place it was about (the input pose, configuration,
platform or block). A malformed event is counted and skipped, never raised.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from planner.domains.kitchen.geometry import BlockPose, KitchenGeometry
from planner.domains.kitchen.plan_io import PlanFileError, decode
from planner.domains.kitchen.values import Conf, Grasp, Trajectory
from planner.domains.kitchen.world import block_pose_to_pose
from planner.sim.transforms import Pose, Vec3, multiply, planar_pose

log = logging.getLogger(__name__)

GhostKind = Literal["placement", "grasp", "conf", "motion"]
GHOST_KINDS: tuple[GhostKind, ...] = ("placement", "grasp", "conf", "motion")

WARN_SKIPPED = 5  # malformed events logged as warnings per fold; the rest at debug level
FAILED_POSE_Z = 0.08  # a failed query about a block pose is marked this high above the block
FAILED_CONF_Z = 0.05  # one about a configuration this high over its base
FAILED_PLATFORM_Z = 0.03  # and one about a platform this far above its top face

Q_LOW = np.array([46, 160, 67], dtype=np.float64)  # green: the lowest predicted cost seen
Q_MID = np.array([235, 190, 30], dtype=np.float64)  # yellow: half way
Q_HIGH = np.array([215, 45, 40], dtype=np.float64)  # red: the highest predicted cost seen
NO_PREDICTION = (120, 120, 125)  # grey: no model prediction for the node (baseline planner)


@dataclass(frozen=True)
class Ghost:
    """One sampled value drawn where it lies, belonging to tree node ``node_id``."""

    node_id: int
    kind: GhostKind
    pose: Pose  # placement: block centre; grasp: tool frame; conf: base on the floor; motion: start
    size: float = 0.0  # placement: the block's edge, metres
    path: tuple[Vec3, ...] = ()  # motion: the base's path on the floor


@dataclass
class TreeNode:
    node_id: int
    parent_id: int | None
    level: int  # edges from the root
    success: bool
    children: list[int] = field(default_factory=list)


@dataclass(frozen=True)
class Failure:
    """A failed query (a node with ``success`` false) and where it was about, if known."""

    node_id: int
    stream: str
    where: Vec3 | None


class SearchFold:
    """The search of one kitchen run, built up event by event."""

    def __init__(self, geometry: KitchenGeometry, seed: int) -> None:
        self.geometry = geometry
        self.initial = geometry.initial_poses(seed)
        self.events = 0  # events folded, the malformed ones included
        self.skipped = 0  # malformed events
        self.nodes: dict[int, TreeNode] = {}
        self.ghosts: dict[GhostKind, list[Ghost]] = {kind: [] for kind in GHOST_KINDS}
        self.failures: list[Failure] = []
        self.q: dict[int, float] = {}  # node id -> predicted remaining seconds (learned planner)
        self.solution: int | None = None  # the node that binds the whole plan, once found
        self._pending: dict[int, Mapping[str, Any]] = {}  # stream_queried by the node it made
        self._effective: dict[int, float | None] | None = None  # _effective_q until next fold
        self._blocks = {b.name: b for b in geometry.blocks}
        self._platforms = {p.name: p for p in geometry.platforms}

    # --- folding -------------------------------------------------------------------------------

    def fold(self, event: Mapping[str, Any]) -> None:
        """Take one more event; a malformed one is logged and skipped."""
        self.events += 1
        self._effective = None
        try:
            kind = event.get("type")
            if kind == "node_added":
                self._node_added(event)
            elif kind == "stream_queried":
                self._pending[_int(event["node_id"])] = event
            elif kind == "model_prediction":
                q = float(event["q"])
                if not math.isfinite(q):
                    raise ValueError(f"q must be finite, got {q}")
                self.q[_int(event["node_id"])] = q
            elif kind == "solution_found":
                self.solution = _int(event["node_id"])
        except (AttributeError, KeyError, TypeError, ValueError, PlanFileError) as exc:
            self.skipped += 1
            level = logging.WARNING if self.skipped <= WARN_SKIPPED else logging.DEBUG
            log.log(level, "viewer: skipped a malformed event (%s): %s", _describe(event), exc)

    def _node_added(self, event: Mapping[str, Any]) -> None:
        node_id = _int(event["node_id"])
        raw_parent = event["parent_id"]
        parent_id = None if raw_parent is None else _int(raw_parent)
        success = event["success"]
        if not isinstance(success, bool):
            raise TypeError(f"success must be a bool, got {success!r}")
        stream = event.get("stream")
        if node_id in self.nodes:
            raise ValueError(f"node {node_id} was added before")
        if parent_id == node_id:
            raise ValueError(f"node {node_id} is its own parent")
        query = self._pending.pop(node_id, None)
        parent = None if parent_id is None else self.nodes.get(parent_id)
        if parent_id is not None and parent is None:
            # The planner never announces the root; an unseen parent starts a tree of its own.
            parent = TreeNode(parent_id, None, 0, True)
        level = 0 if parent is None else parent.level + 1
        # Read everything first: a malformed event leaves the fold as it was.
        failure: Failure | None = None
        ghosts: list[Ghost] = []
        if stream is not None and not success:
            failure = Failure(node_id, str(stream), self._where(query))
        elif stream is not None:
            block = self._block_of(query)
            outputs = event["outputs"]
            if not isinstance(outputs, list):
                raise TypeError(f"outputs must be a list, got {type(outputs).__name__}")
            for raw in outputs:
                ghost = self._ghost(node_id, decode(raw, f"node {node_id} output"), block)
                if ghost is not None:
                    ghosts.append(ghost)
        self.nodes[node_id] = TreeNode(node_id, parent_id, level, success)
        if parent is not None:
            self.nodes.setdefault(parent.node_id, parent).children.append(node_id)
        if failure is not None:
            self.failures.append(failure)
        for ghost in ghosts:
            self.ghosts[ghost.kind].append(ghost)

    def _ghost(self, node_id: int, value: Any, block: str | None) -> Ghost | None:
        if isinstance(value, BlockPose):
            size = self._blocks[block].size if block else self.geometry.blocks[0].size
            return Ghost(node_id, "placement", block_pose_to_pose(value), size)
        if isinstance(value, Grasp):
            if block is None:
                return None
            at = block_pose_to_pose(self.initial[block])
            return Ghost(node_id, "grasp", multiply(at, value.tool_in_block))
        if isinstance(value, Conf):
            return Ghost(node_id, "conf", planar_pose(*value.base))
        if isinstance(value, Trajectory):
            path = _base_path(value)
            start = (path[0][0], path[0][1], 0.0)
            return Ghost(node_id, "motion", (start, (0.0, 0.0, 0.0, 1.0)), path=path)
        return None

    def _block_of(self, query: Mapping[str, Any] | None) -> str | None:
        """The block a query was about (its first input naming a block)."""
        if query is None:
            return None
        for raw in query.get("inputs", ()):
            if isinstance(raw, str) and raw in self._blocks:
                return raw
        return None

    def _where(self, query: Mapping[str, Any] | None) -> Vec3 | None:
        """Where a failed query was about: its input pose, else the configuration it was to
        reach, else the platform, else the block at its initial pose."""
        if query is None:
            return None
        values = []
        for raw in query.get("inputs", ()):
            try:
                values.append(decode(raw, "query input"))
            except PlanFileError:
                continue  # a malformed input tells nothing about the place
        for v in values:
            if isinstance(v, BlockPose):
                return (v.x, v.y, v.z + FAILED_POSE_Z)
        confs = [v for v in values if isinstance(v, Conf)]
        if confs:
            x, y, _ = confs[-1].base
            return (x, y, FAILED_CONF_Z)
        for v in values:
            if isinstance(v, str) and v in self._platforms:
                plat = self._platforms[v]
                return (plat.center[0], plat.center[1], plat.top + FAILED_PLATFORM_Z)
        for v in values:
            if isinstance(v, str) and v in self.initial:
                p = self.initial[v]
                return (p.x, p.y, p.z + FAILED_POSE_Z)
        return None

    # --- reading -------------------------------------------------------------------------------

    @property
    def failed(self) -> int:
        """Failed queries seen (a failed query makes a node with ``success`` false)."""
        return len(self.failures)

    def colors(self, node_ids: Sequence[int]) -> npt.NDArray[np.uint8]:
        """One RGB row per node: its predicted Q on a green-yellow-red scale spread over every
        Q seen so far; a node without a prediction of its own (one made in a simulation) takes
        its nearest predicted ancestor's; grey when there is none."""
        out = np.empty((len(node_ids), 3), dtype=np.uint8)
        out[:] = NO_PREDICTION
        if not self.q or not node_ids:
            return out
        lo, hi = min(self.q.values()), max(self.q.values())
        effective = self._effective_q()
        q = np.array([effective.get(n) for n in node_ids], dtype=np.float64)  # None -> nan
        known = ~np.isnan(q)
        t = np.clip((q[known] - lo) / (hi - lo), 0.0, 1.0) if hi > lo else np.zeros(known.sum())
        low = t[:, None] < 0.5
        first = Q_LOW + (Q_MID - Q_LOW) * (t[:, None] / 0.5)
        second = Q_MID + (Q_HIGH - Q_MID) * ((t[:, None] - 0.5) / 0.5)
        out[known] = np.where(low, first, second).astype(np.uint8)
        return out

    def _effective_q(self) -> dict[int, float | None]:
        """Each node's Q, or its nearest predicted ancestor's (None: no prediction above it)."""
        if self._effective is not None:
            return self._effective
        effective: dict[int, float | None] = {}
        self._effective = effective
        for start in self.nodes:
            chain: list[int] = []
            current: int | None = start
            value: float | None = None
            while current is not None:
                if current in effective:
                    value = effective[current]
                    break
                if current in self.q:
                    value = effective[current] = self.q[current]
                    break
                chain.append(current)
                node = self.nodes.get(current)
                current = None if node is None else node.parent_id
            for node_id in chain:
                effective[node_id] = value
        return effective

    def q_range(self) -> tuple[float, float] | None:
        if not self.q:
            return None
        return (min(self.q.values()), max(self.q.values()))

    def solution_path(self) -> list[int]:
        """Node ids from the root to the solution (empty before one is found)."""
        path: list[int] = []
        current = self.solution
        while current is not None and current in self.nodes and current not in path:
            path.append(current)
            current = self.nodes[current].parent_id
        return path[::-1]


def tree_layout(nodes: Mapping[int, TreeNode]) -> dict[int, tuple[float, int]]:
    """``(across, level)`` of every node reachable from a root: leaves evenly spaced in
    ``[0, 1]`` in depth-first order, each parent centred over its first and last child."""
    across: dict[int, float] = {}
    leaves: list[int] = []
    roots = [n.node_id for n in nodes.values() if n.level == 0]
    for root in roots:
        stack: list[tuple[int, bool]] = [(root, False)]
        while stack:
            node_id, done = stack.pop()
            node = nodes[node_id]
            kids = [c for c in node.children if c in nodes]
            if not kids:
                across[node_id] = float(len(leaves))
                leaves.append(node_id)
            elif done:
                across[node_id] = (across[kids[0]] + across[kids[-1]]) / 2
            else:
                stack.append((node_id, True))
                stack.extend((c, False) for c in reversed(kids))
    scale = 1.0 / (len(leaves) - 1) if len(leaves) > 1 else 0.0
    return {n: (a * scale if len(leaves) > 1 else 0.5, nodes[n].level) for n, a in across.items()}


def _base_path(traj: Trajectory) -> tuple[Vec3, ...]:
    """The base's positions along a trajectory, on the floor, without repeats."""
    points: list[Vec3] = []
    for seg in traj.segments:
        for x, y, _ in seg.base:
            if not points or math.dist(points[-1][:2], (x, y)) > 1e-9:
                points.append((x, y, 0.0))
    if not points:
        x, y, _ = traj.start.base
        points.append((x, y, 0.0))
    return tuple(points)


def _int(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"expected an integer id, got {value!r}")
    return value


def _describe(event: Any) -> str:
    if isinstance(event, Mapping):
        return f"{event.get('type')!r} #{event.get('seq')}"
    return type(event).__name__
