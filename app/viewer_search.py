"""A run's search tree folded from its events into what the 3D view draws (no viser here).

:class:`SearchFold` takes event dicts exactly as :func:`planner.events.event_to_dict` makes them,
one at a time, and keeps the tree's shape, each node's predicted cost ``Q`` and, when the domain
has a 3D view (``DomainSpec.view``), the ghosts its hook draws for each successful sample
(markers in named layers) and where each failed query was about. Query inputs and outputs are
decoded with the domain's value types. A malformed event, or one the domain's hook cannot draw,
is counted and skipped, never raised.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from planner import figures
from planner.domains import LoadedDomain
from planner.pddl.structs import Problem
from planner.values import ValueDecodeError
from planner.view import DomainView, Marker, QueryView, Vec3

log = logging.getLogger(__name__)

WARN_SKIPPED = 5  # malformed events logged as warnings per fold; the rest at debug level

NO_PREDICTION = figures.NO_PREDICTION_RGB  # grey: no model prediction (the baseline planner)


@dataclass(frozen=True)
class Ghost:
    """One marker of a sampled value, belonging to tree node ``node_id``."""

    node_id: int
    marker: Marker


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
    """The search of one run, built up event by event; ``view`` draws its samples (None: the
    tree alone)."""

    def __init__(
        self, loaded: LoadedDomain, problem: Problem, view: DomainView | None = None
    ) -> None:
        self.loaded = loaded
        self.problem = problem
        self.view = view
        self.events = 0  # events folded, the malformed ones included
        self.skipped = 0  # malformed events
        self.nodes: dict[int, TreeNode] = {}
        self.ghosts: dict[str, list[Ghost]] = {}  # layer -> ghosts, in order
        self.failures: list[Failure] = []
        self.q: dict[int, float] = {}  # node id -> predicted remaining seconds (learned planner)
        self.solution: int | None = None  # the node that binds the whole plan, once found
        self.queries: dict[int, QueryView] = {}  # a successful node's query, decoded
        self.labels: dict[int, str] = {}  # each node's label (its event's)
        self._pending: dict[int, Mapping[str, Any]] = {}  # stream_queried by the node it made
        self._effective: dict[int, float | None] | None = None  # _effective_q until next fold
        self._scale: tuple[float, float] | None = None  # q_range, kept until the next fold
        self._scale_stale = True

    # --- folding -------------------------------------------------------------------------------

    def fold(self, event: Mapping[str, Any]) -> None:
        """Take one more event; a malformed one is logged and skipped."""
        self.events += 1
        self._effective = None
        self._scale_stale = True
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
        except (AttributeError, KeyError, TypeError, ValueError, IndexError) as exc:
            self.skipped += 1
            level = logging.WARNING if self.skipped <= WARN_SKIPPED else logging.DEBUG
            log.log(level, "viewer: skipped a malformed event (%s): %s", _describe(event), exc)

    def _inputs(self, query: Mapping[str, Any] | None) -> tuple[Any, ...]:
        if query is None:
            return ()
        out = []
        for i, raw in enumerate(query.get("inputs", ())):
            try:
                out.append(self.loaded.decode(raw, f"input {i}"))
            except ValueDecodeError:
                out.append(None)  # a value the domain cannot read tells nothing about the place
        return tuple(out)

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
        made: QueryView | None = None
        if stream is not None and not success:
            where = None
            if self.view is not None:
                where = self.view.failure_at(
                    QueryView(str(stream), self._inputs(query)), self.problem
                )
            failure = Failure(node_id, str(stream), where)
        elif stream is not None:
            outputs = event["outputs"]
            if not isinstance(outputs, list):
                raise TypeError(f"outputs must be a list, got {type(outputs).__name__}")
            if self.view is not None:
                values = tuple(
                    self.loaded.decode(raw, f"node {node_id} output {i}")
                    for i, raw in enumerate(outputs)
                )
                made = QueryView(str(stream), self._inputs(query), values)
                ghosts = [Ghost(node_id, m) for m in self.view.markers(made, self.problem)]
        self.nodes[node_id] = TreeNode(node_id, parent_id, level, success)
        self.labels[node_id] = str(event.get("label") or stream or "")
        if made is not None:
            self.queries[node_id] = made
        if parent is not None:
            self.nodes.setdefault(parent.node_id, parent).children.append(node_id)
        if failure is not None:
            self.failures.append(failure)
        for ghost in ghosts:
            self.ghosts.setdefault(ghost.marker.layer, []).append(ghost)

    # --- reading -------------------------------------------------------------------------------

    @property
    def failed(self) -> int:
        """Failed queries seen (a failed query makes a node with ``success`` false)."""
        return len(self.failures)

    def colors(self, node_ids: Sequence[int]) -> npt.NDArray[np.uint8]:
        """One RGB row per node, on the page's scale (planner/figures.py): its predicted Q
        between the percentiles of every Q predicted so far, green low to red high; a node
        without a prediction of its own (one made in a simulation) takes its nearest predicted
        ancestor's; grey when there is none."""
        out = np.empty((len(node_ids), 3), dtype=np.uint8)
        out[:] = NO_PREDICTION
        scale = self.q_range()
        if scale is None or not node_ids:
            return out
        lo, hi = scale
        effective = self._effective_q()
        for i, n in enumerate(node_ids):
            q = effective.get(n)
            if q is not None:
                out[i] = figures.q_rgb_at(figures.q_fraction(q, lo, hi))
        return out

    def _effective_q(self) -> dict[int, float | None]:
        """Each node's Q for colouring (:func:`planner.figures.effective_q`), kept until the
        next fold."""
        if self._effective is None:
            parents = {n: node.parent_id for n, node in self.nodes.items()}
            self._effective = figures.effective_q(parents, self.q)
        return self._effective

    def q_range(self) -> tuple[float, float] | None:
        """The colour scale: :func:`planner.figures.q_scale` of every Q predicted so far
        (kept until the next fold)."""
        if self._scale_stale:
            self._scale = figures.q_scale(self.q.values())
            self._scale_stale = False
        return self._scale

    def branch(self, node_id: int) -> list[int]:
        """Node ids from the root down to ``node_id`` (empty for a node not in the tree)."""
        path: list[int] = []
        current: int | None = node_id
        while current is not None and current in self.nodes and current not in path:
            path.append(current)
            current = self.nodes[current].parent_id
        return path[::-1]

    def branch_queries(self, node_id: int) -> list[QueryView]:
        """The successful queries on the branch down to ``node_id``, in order."""
        return [self.queries[n] for n in self.branch(node_id) if n in self.queries]

    def markers_of(self, node_id: int) -> list[Marker]:
        """The ghosts the domain draws for one node's samples (none for a failed node)."""
        query = self.queries.get(node_id)
        if query is None or self.view is None:
            return []
        return list(self.view.markers(query, self.problem))

    def solution_path(self) -> list[int]:
        """Node ids from the root to the solution (empty before one is found)."""
        return [] if self.solution is None else self.branch(self.solution)


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


def _int(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"expected an integer id, got {value!r}")
    return value


def _describe(event: Any) -> str:
    if isinstance(event, Mapping):
        return f"{event.get('type')!r} #{event.get('seq')}"
    return type(event).__name__
