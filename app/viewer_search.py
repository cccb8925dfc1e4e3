"""A run's search tree, folded from its events, with what the 3D view draws of it (no viser
here).

:class:`SearchFold` takes events one at a time, as the store and the websocket carry them
(:func:`planner.events.event_to_dict`'s dicts, or events), folds them into the run's tree with
:mod:`planner.trace` (the fold compare uses too) and, when the domain has a 3D view
(``DomainSpec.view``), keeps the ghosts its hook draws for each successful sample (markers in
named layers) and where each failed query was about. Query inputs and outputs are decoded with
the domain's value types. A malformed event, one that does not fit the tree, or one the
domain's hook cannot draw, is counted and skipped, never raised.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from planner import figures
from planner.domains import LoadedDomain
from planner.events import EVENT_TYPES, Event, NodeAdded, StreamQueried, event_from_dict
from planner.pddl.structs import Problem
from planner.trace import Trace, TraceError
from planner.values import ValueDecodeError
from planner.view import DomainView, Marker, QueryView, Vec3

log = logging.getLogger(__name__)

WARN_SKIPPED = 5  # malformed events logged as warnings per fold; the rest at debug level

EVENT_CLASSES = frozenset(EVENT_TYPES.values())
NO_PREDICTION = figures.NO_PREDICTION_RGB  # grey: no model prediction (the baseline planner)


@dataclass(frozen=True)
class Ghost:
    """One marker of a sampled value, belonging to tree node ``node_id``."""

    node_id: int
    marker: Marker


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
        self.trace = Trace()
        self.ghosts: dict[str, list[Ghost]] = {}  # layer -> ghosts, in order
        self.failures: list[Failure] = []
        self.queries: dict[int, QueryView] = {}  # a successful node's query, decoded
        self._effective: dict[int, float | None] | None = None  # _effective_q until next fold
        self._scale: tuple[float, float] | None = None  # q_range, kept until the next fold
        self._scale_stale = True

    # --- folding -------------------------------------------------------------------------------

    def fold(self, raw: Event | Mapping[str, Any]) -> None:
        """Take one more event; a malformed one is logged and skipped."""
        self.events += 1
        self._effective = None
        self._scale_stale = True
        try:
            if isinstance(raw, Mapping):
                event = event_from_dict(dict(raw))
            elif type(raw) in EVENT_CLASSES:
                event = raw
            else:
                raise TypeError(f"not an event: {type(raw).__name__}")
            if isinstance(event, NodeAdded) and event.parent_id is not None:
                self._node_added(event)
            else:
                self.trace.apply(event)
        # TraceError and ValueDecodeError are ValueErrors; the rest from the domain's hook
        except (AttributeError, IndexError, KeyError, TypeError, ValueError) as exc:
            self.skipped += 1
            level = logging.WARNING if self.skipped <= WARN_SKIPPED else logging.DEBUG
            log.log(level, "viewer: skipped a malformed event (%s): %s", _describe(raw), exc)

    def _inputs(self, query: StreamQueried | None) -> tuple[Any, ...]:
        if query is None:
            return ()
        out = []
        for i, raw in enumerate(query.inputs):
            try:
                out.append(self.loaded.decode(raw, f"input {i}"))
            except ValueDecodeError:
                out.append(None)  # a value the domain cannot read tells nothing about the place
        return tuple(out)

    def _node_added(self, event: NodeAdded) -> None:
        """A node below the root: what the domain draws of it is made first, so an event it
        cannot draw (or one that does not fit the tree) leaves the fold as it was."""
        if event.node_id in self.trace:
            raise TraceError(f"node {event.node_id} was added before")
        query = self.trace.pending(event.node_id)
        stream, node_id = event.stream, event.node_id
        failure: Failure | None = None
        ghosts: list[Ghost] = []
        made: QueryView | None = None
        if stream is not None and not event.success:
            where = None
            if self.view is not None:
                where = self.view.failure_at(QueryView(stream, self._inputs(query)), self.problem)
            failure = Failure(node_id, stream, where)
        elif stream is not None and self.view is not None:
            values = tuple(
                self.loaded.decode(raw, f"node {node_id} output {i}")
                for i, raw in enumerate(event.outputs)
            )
            made = QueryView(stream, self._inputs(query), values)
            ghosts = [Ghost(node_id, m) for m in self.view.markers(made, self.problem)]
        self.trace.apply(event)
        if made is not None:
            self.queries[node_id] = made
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
            self._effective = figures.effective_q(self.trace.parents(), self.trace.predictions())
        return self._effective

    def q_range(self) -> tuple[float, float] | None:
        """The colour scale: :func:`planner.figures.q_scale` of every Q predicted so far
        (kept until the next fold)."""
        if self._scale_stale:
            self._scale = figures.q_scale(self.trace.predictions().values())
            self._scale_stale = False
        return self._scale

    def label(self, node_id: int, default: str = "") -> str:
        """The node's label (its stream's name if it has none); ``default`` for a node not in
        the tree."""
        if node_id not in self.trace:
            return default
        node = self.trace[node_id]
        return node.label or node.stream or ""

    def branch_queries(self, node_id: int) -> list[QueryView]:
        """The successful queries on the branch down to ``node_id``, in order."""
        return [self.queries[n] for n in self.trace.branch(node_id) if n in self.queries]

    def markers_of(self, node_id: int) -> list[Marker]:
        """The ghosts the domain draws for one node's samples (none for a failed node)."""
        query = self.queries.get(node_id)
        if query is None or self.view is None:
            return []
        return list(self.view.markers(query, self.problem))


def tree_layout(trace: Trace) -> dict[int, tuple[float, int]]:
    """``(across, level)`` of every node the view shows (:attr:`Trace.shown`): leaves evenly
    spaced in ``[0, 1]`` in depth-first order, each parent centred over its first and last
    child."""
    if not trace.shown:
        return {}
    across: dict[int, float] = {}
    leaves: list[int] = []
    stack: list[tuple[int, bool]] = [(trace.root, False)]
    while stack:
        node_id, done = stack.pop()
        kids = trace[node_id].children
        if not kids:
            across[node_id] = float(len(leaves))
            leaves.append(node_id)
        elif done:
            across[node_id] = (across[kids[0]] + across[kids[-1]]) / 2
        else:
            stack.append((node_id, True))
            stack.extend((c, False) for c in reversed(kids))
    scale = 1.0 / (len(leaves) - 1) if len(leaves) > 1 else 0.0
    return {n: (a * scale if len(leaves) > 1 else 0.5, trace[n].level) for n, a in across.items()}


def _describe(event: object) -> str:
    if isinstance(event, Mapping):
        return f"{event.get('type')!r} #{event.get('seq')}"
    if type(event) in EVENT_CLASSES:
        return f"{getattr(event, 'type', '?')!r} #{getattr(event, 'seq', '?')}"
    return type(event).__name__
