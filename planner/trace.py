"""A run's search tree as its events tell it: the one writer of node events and the one fold of
events back into the tree.

:class:`NodeEvents` is how every planner reports its tree (the tree search,
:mod:`planner.search.mcts`, and the sequential binder, :mod:`planner.planners`): a stream plan
opened under the root, a query and the node it made (``stream_queried`` right before its
``node_added``), a back-up, a model's prediction, the solution.

:class:`Trace` folds a run's events, one at a time, into that tree: nodes with their parent,
children, stream, label, outcome, the query that made them and their latest model prediction;
the skeletons, the solution and how the run ended. The compare view (:mod:`app.compare`, which
serves it to the page as columns) and the 3D view (:mod:`app.viewer_search`) read it. The page
folds live events in JavaScript (``static/tree.js``, which steps back and forth through a run)
by the same rules, with the event type and status names of ``/generated/definitions.js``
(:func:`planner.figures.definitions`), never copies of them.

Tree rules (:mod:`planner.events`): the root (node 0 unless a ``node_added`` without a parent
names it) is never announced by the searches, so a trace starts with it; its children are the
stream plans; a node at depth ``d >= 1`` is one result of querying the plan's ``d``-th stream.
An event that does not fit the tree (a node added twice, a parent not seen) raises
:class:`TraceError` and leaves the trace as it was.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, TypeAlias, get_args

from planner.abstract.instantiate import StreamInstance
from planner.events import (
    AbstractPlansFound,
    Emitter,
    Event,
    ModelPrediction,
    NodeAdded,
    NodeVisited,
    RunCancelled,
    RunFailed,
    RunFinished,
    RunStarted,
    SkeletonsAdded,
    SolutionFound,
    StreamQueried,
)
from planner.streams.runtime import QueryResult

log = logging.getLogger(__name__)

ROOT_ID = 0  # the root's id when no node_added names it (the searches never do)

# What a node is: the root, a stream plan under it, or the result of one query.
NodeKind: TypeAlias = Literal["root", "plan", "ok", "failed"]
NODE_KINDS: tuple[NodeKind, ...] = get_args(NodeKind)

RunEnd: TypeAlias = RunFinished | RunFailed | RunCancelled


class TraceError(ValueError):
    """An event that does not fit the tree folded so far."""


# --- writing ---------------------------------------------------------------------------------


def plan_label(plan_index: int, streams: int) -> str:
    """A stream plan node's label."""
    return f"plan {plan_index} ({streams} streams)"


def query_label(inst: StreamInstance, success: bool) -> str:
    """The label of the node a query of ``inst`` made."""
    return f"{inst}" + ("" if success else " (failed)")


class NodeEvents:
    """Reports a search's tree as events: every planner's nodes, queries and solution go
    through here, so they carry the same fields, labels and encodings.

    ``encode`` turns a value into its JSON (the domain's codec); ``describe`` an encoded value
    into one line for people (None: no labels)."""

    def __init__(
        self,
        emitter: Emitter,
        *,
        encode: Callable[[Any], Any],
        describe: Callable[[Any], str] | None = None,
    ) -> None:
        self.emitter = emitter
        self.encode = encode
        self.describe = describe

    def _labels(self, encoded: Sequence[Any]) -> list[str]:
        return [] if self.describe is None else [self.describe(v) for v in encoded]

    def plan_opened(self, node_id: int, plan_index: int, streams: int) -> NodeAdded:
        """A stream plan of ``streams`` streams opened under the root as node ``node_id``."""
        return self.emitter.emit(
            NodeAdded,
            node_id=node_id,
            parent_id=ROOT_ID,
            plan_index=plan_index,
            depth=0,
            stream=None,
            success=True,
            outputs=[],
            label=plan_label(plan_index, streams),
        )

    def queried(
        self,
        *,
        node_id: int,
        parent_id: int,
        plan_index: int,
        depth: int,
        inst: StreamInstance,
        inputs: Sequence[Any],
        context: dict[str, Any],
        result: QueryResult,
        reused_from: int | None = None,
    ) -> tuple[StreamQueried, NodeAdded]:
        """A query of ``inst`` below node ``parent_id`` that made node ``node_id`` (at
        ``depth``, its plan's ``depth``-th stream): its ``stream_queried``, then its
        ``node_added``. ``context`` is the query's recorded world (JSON);
        ``reused_from`` the node whose identical query gave this answer (None: a sampler
        ran)."""
        encoded = [self.encode(v) for v in inputs]
        query = self.emitter.emit(
            StreamQueried,
            node_id=node_id,
            stream=inst.stream,
            input_names=list(inst.inputs),
            inputs=encoded,
            input_labels=self._labels(encoded),
            success=result.success,
            wall_s=result.wall_s,
            cpu_s=result.cpu_s,
            execution_s=result.execution_s,
            error=result.error,
            context=context,
            reused_from=reused_from,
            reason=result.reason,
        )
        outputs = [self.encode(v) for v in result.outputs or ()]
        node = self.emitter.emit(
            NodeAdded,
            node_id=node_id,
            parent_id=parent_id,
            plan_index=plan_index,
            depth=depth,
            stream=inst.stream,
            success=result.success,
            outputs=outputs,
            label=query_label(inst, result.success),
            output_names=list(inst.outputs) if result.outputs is not None else [],
            output_labels=self._labels(outputs),
        )
        return query, node

    def visited(self, node_id: int, visits: int, value: float) -> NodeVisited:
        """Node ``node_id`` after a back-up."""
        return self.emitter.emit(NodeVisited, node_id=node_id, visits=visits, value=value)

    def predicted(
        self, node_id: int, *, p_s: float, r_s: float, r_f: float, r_m: float, q: float
    ) -> ModelPrediction:
        """The learned models' view of node ``node_id``: Eq. 1-3 of its next stream, Eq. 4's
        ``q``."""
        return self.emitter.emit(
            ModelPrediction, node_id=node_id, p_s=p_s, r_s=r_s, r_f=r_f, r_m=r_m, q=q
        )

    def solved(
        self,
        node_id: int,
        plan_index: int,
        *,
        planning_s: float,
        execution_s: float,
        oracle_s: float,
    ) -> SolutionFound:
        """Node ``node_id`` binds all of plan ``plan_index``."""
        return self.emitter.emit(
            SolutionFound,
            node_id=node_id,
            plan_index=plan_index,
            planning_s=planning_s,
            execution_s=execution_s,
            oracle_s=oracle_s,
        )


# --- reading ---------------------------------------------------------------------------------


@dataclass
class TraceNode:
    """One node of the folded tree."""

    id: int
    parent: int | None  # None for the root
    plan_index: int  # -1 for the root
    depth: int  # 0 for the root and the stream plans; d: a result of the plan's d-th stream
    level: int  # edges from the root: 0 root, 1 stream plans, d + 1 results of the d-th stream
    stream: str | None  # the stream queried to make it; None for the root and the stream plans
    success: bool
    label: str
    outputs: list[Any] = field(default_factory=list)  # JSON of the values its query bound
    output_names: list[str] = field(default_factory=list)
    output_labels: list[str] = field(default_factory=list)
    children: list[int] = field(default_factory=list)  # in the order they were made
    t: float = 0.0  # when it was added (seconds since the run started)
    query: StreamQueried | None = None  # the query that made it (None: root, stream plan)
    prediction: ModelPrediction | None = None  # the latest model prediction for it
    visit: NodeVisited | None = None  # its latest back-up
    announced: bool = True  # False: the root, before a node_added names it (if one ever does)

    @property
    def kind(self) -> NodeKind:
        if self.parent is None:
            return "root"
        if self.stream is None:
            return "plan"
        return "ok" if self.success else "failed"

    @property
    def q(self) -> float | None:
        """The latest predicted remaining seconds (Eq. 4) for it; None without one."""
        return None if self.prediction is None else self.prediction.q


class Trace:
    """A run's search tree, folded from its events (:meth:`apply`), with what a view of the
    run needs around it: the skeletons, the solution, how the run ended."""

    def __init__(self) -> None:
        root = TraceNode(ROOT_ID, None, -1, 0, 0, None, True, "root", announced=False)
        self.root = ROOT_ID
        self.nodes: dict[int, TraceNode] = {ROOT_ID: root}
        self.order: list[int] = [ROOT_ID]  # node ids as they were made, the root first
        self.events = 0  # events applied
        self.run: RunStarted | None = None
        self.plans: list[dict[str, Any]] = []  # abstract_plans_found's, then skeletons_added's
        self.plans_t: float | None = None  # t of abstract_plans_found: the first skeletons
        self.later_skeletons_s = 0.0  # seconds of the skeletons the search asked for after
        self.solution: SolutionFound | None = None
        self.end: RunEnd | None = None
        self.failed = 0  # nodes whose query failed
        self._pending: dict[int, StreamQueried] = {}  # a query, until the node it made comes

    # --- folding -------------------------------------------------------------------------------

    def apply(self, event: Event) -> None:
        """Fold one more event in; :class:`TraceError` (the trace unchanged) when it does not
        fit the tree."""
        if isinstance(event, NodeAdded):
            self._node_added(event)
        elif isinstance(event, StreamQueried):
            self._pending[event.node_id] = event
        elif isinstance(event, ModelPrediction):
            self._node(event.node_id, event).prediction = event
        elif isinstance(event, NodeVisited):
            self._node(event.node_id, event).visit = event
        elif isinstance(event, SolutionFound):
            self._node(event.node_id, event)
            self.solution = event
        elif isinstance(event, AbstractPlansFound):
            if self.plans_t is None:
                self.plans = list(event.plans)
                self.plans_t = event.t
        elif isinstance(event, SkeletonsAdded):
            self.plans += event.plans
            self.later_skeletons_s += event.seconds
        elif isinstance(event, RunStarted):
            self.run = event
        elif isinstance(event, RunFinished | RunFailed | RunCancelled):
            self.end = event
        self.events += 1

    def _node(self, node_id: int, event: Event) -> TraceNode:
        node = self.nodes.get(node_id)
        if node is None:
            raise TraceError(f"{event.type} #{event.seq}: no node {node_id} in the tree")
        return node

    def _node_added(self, e: NodeAdded) -> None:
        if e.parent_id is None:
            self._root_added(e)
            return
        if e.node_id in self.nodes:
            raise TraceError(f"node_added #{e.seq}: node {e.node_id} was added before")
        parent = self.nodes.get(e.parent_id)
        if parent is None:
            raise TraceError(f"node_added #{e.seq}: parent {e.parent_id} is not in the tree")
        node = TraceNode(
            e.node_id,
            e.parent_id,
            e.plan_index,
            e.depth,
            parent.level + 1,
            e.stream,
            e.success,
            e.label,
            e.outputs,
            e.output_names,
            e.output_labels,
            t=e.t,
            query=self._pending.pop(e.node_id, None),
        )
        self.nodes[node.id] = node
        self.order.append(node.id)
        parent.children.append(node.id)
        if not node.success:
            self.failed += 1

    def _root_added(self, e: NodeAdded) -> None:
        root = self.nodes[self.root]
        if root.announced:
            raise TraceError(f"node_added #{e.seq}: a second root ({e.node_id})")
        if e.node_id != root.id:
            if e.node_id in self.nodes:
                raise TraceError(f"node_added #{e.seq}: node {e.node_id} was added before")
            del self.nodes[root.id]
            for child in root.children:
                self.nodes[child].parent = e.node_id
            root.id = self.root = self.order[0] = e.node_id
            self.nodes[root.id] = root
        root.label = e.label or "root"
        root.t = e.t
        root.announced = True

    # --- reading -------------------------------------------------------------------------------

    def __len__(self) -> int:
        """Nodes, the root included."""
        return len(self.order)

    @property
    def shown(self) -> int:
        """Nodes a view shows: every announced one, the root once it has children (as the
        page counts them)."""
        root = self.nodes[self.root]
        return 0 if len(self.order) == 1 and not root.announced else len(self.order)

    def __getitem__(self, node_id: int) -> TraceNode:
        return self.nodes[node_id]

    def __contains__(self, node_id: object) -> bool:
        return node_id in self.nodes

    def pending(self, node_id: int) -> StreamQueried | None:
        """The query that will make node ``node_id``, before its node_added comes."""
        return self._pending.get(node_id)

    def ordered(self) -> list[TraceNode]:
        """Every node as they were made, the root first."""
        return [self.nodes[n] for n in self.order]

    def branch(self, node_id: int) -> list[int]:
        """Node ids from the root down to ``node_id`` (empty for a node not in the tree)."""
        path: list[int] = []
        current: int | None = node_id
        while current is not None and current in self.nodes:
            path.append(current)
            current = self.nodes[current].parent
        return path[::-1]

    def solution_path(self) -> list[int]:
        """Node ids from the root to the solution (empty before one is found)."""
        return [] if self.solution is None else self.branch(self.solution.node_id)

    def predictions(self) -> dict[int, float]:
        """Node id -> its latest predicted Q, for the nodes that have one."""
        return {n.id: n.prediction.q for n in self.nodes.values() if n.prediction is not None}

    def parents(self) -> dict[int, int | None]:
        """Node id -> its parent's (None for the root)."""
        return {n.id: n.parent for n in self.nodes.values()}


def fold(events: Iterable[Event], trace: Trace | None = None) -> Trace:
    """``events`` folded into ``trace`` (a new one by default). An event that does not fit the
    tree is logged and left out: a view of a stored run shows what fits."""
    out = Trace() if trace is None else trace
    skipped = 0
    for event in events:
        try:
            out.apply(event)
        except TraceError as exc:
            skipped += 1
            if skipped == 1:
                log.warning("%s", exc)
    if skipped > 1:
        log.warning("%d events of the run did not fit its tree and were left out", skipped)
    return out
