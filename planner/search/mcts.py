"""The tree search over stream bindings: selection, expansion, simulation, back-propagation.

The loop is here (:class:`TreeSearch`); what it selects is decided by a :class:`Policy`: eTAMP's
progressive widening (:class:`BaselinePolicy`) or the learned policy
(:class:`planner.search.learned.LearnedPolicy`, the planners ``paper`` and ``learned``). A search
ends when a plan is fully bound, every stream plan is exhausted, its deadline passes, a bound on
its queries or iterations is reached (:mod:`planner.search.bounds`), or its caller stops it.
Every step is reported as an event (:mod:`planner.events`).
"""

from __future__ import annotations

import contextlib
import gc
import logging
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from planner.abstract.instantiate import StreamInstance
from planner.abstract.skeleton import AbstractPlan
from planner.abstract.source import Feedback
from planner.events import Emitter
from planner.pddl.structs import Atom
from planner.search.baseline import (
    BaselineConfig,
    failure_value,
    should_widen,
    success_value,
    ucb,
)
from planner.search.bounds import SearchBounds
from planner.search.feedback import InstanceKey, InstanceRecords
from planner.search.queries import query_context, query_identity, remembered
from planner.search.reuse import reusable_streams
from planner.search.tree import ROOT, Node, Tree
from planner.status import SearchStatus
from planner.streams.adapters import StreamContext
from planner.streams.runtime import QueryResult, StreamRuntime
from planner.trace import NodeEvents

log = logging.getLogger(__name__)


class Policy(Protocol):
    """What the loop asks at each step; pure decisions over the tree's numbers."""

    def initial_plans(self, total: int) -> int:
        """How many stream plans to open before the first iteration."""
        ...

    def add_plan(self, tree: Tree, plans_added: int, plans_total: int) -> bool:
        """At the root: open the next stream plan (True) or descend into an open one."""
        ...

    def pick_plan(self, tree: Tree) -> Node:
        """At the root: which open stream plan to descend into."""
        ...

    def expand(self, tree: Tree, node: Node) -> bool:
        """Inside a plan: query the node's next stream again (True) or descend."""
        ...

    def pick_child(self, tree: Tree, node: Node) -> Node:
        """Inside a plan: which successful child to descend into."""
        ...

    def leaf_value(self, leaf: Node, plan: AbstractPlan) -> float:
        """The value of a failed query or a fully bound plan."""
        ...

    def observe(self, tree: Tree, nodes: Sequence[Node]) -> None:
        """The nodes one iteration made (its expansion and rollout), after its backup."""
        ...

    def ask_more(self, tree: Tree, plans_open: int, asked: int, ask_s: float) -> bool:
        """At the root, every known stream plan open: ask the skeleton source for more (True)
        or descend into an open one. ``asked``: requests so far; ``ask_s``: the seconds a
        request has taken on average."""
        ...

    def plans_added(
        self,
        skeletons: Sequence[AbstractPlan],
        states: Sequence[Sequence[frozenset[Atom]]],
    ) -> None:
        """The search's stream plans (and their states) after a request brought more."""
        ...

    def doubts(self, instances: frozenset[InstanceKey]) -> None:
        """The stream instances the search now doubts (asked ``doubt_after`` times or proved
        false, never successful), by stream and inputs, after each change."""
        ...


class SkeletonFeed(Protocol):
    """Where a search gets more stream plans: a skeleton source and what prepares its plans for
    the search (their states, a model's stream order), reporting them as events."""

    def more(
        self, reason: str, feedback: Feedback
    ) -> list[tuple[AbstractPlan, list[frozenset[Atom]]]]:
        """New stream plans with their states, planned on what ``feedback`` says (empty: the
        source has nothing new for it)."""
        ...

    def exhausted_for(self, feedback: Feedback) -> bool:
        """Whether a request with this feedback is known to bring nothing new."""
        ...

    @property
    def requests(self) -> int:
        """Requests made so far, the first batch's included."""
        ...

    @property
    def seconds(self) -> float:
        """Wall seconds the source has worked, the first batch's included."""
        ...


@dataclass(frozen=True)
class BaselinePolicy:
    """eTAMP's progressive-widening UCT (Ren et al.)."""

    config: BaselineConfig = field(default_factory=BaselineConfig)

    def initial_plans(self, total: int) -> int:
        return 0  # plans are opened one by one by the root's widening rule

    def add_plan(self, tree: Tree, plans_added: int, plans_total: int) -> bool:
        if plans_added >= plans_total:
            return False
        root = tree[ROOT]
        return plans_added == 0 or root.visits > self.config.root_widen_k * plans_added**2

    def pick_plan(self, tree: Tree) -> Node:
        root = tree[ROOT]
        return max(
            tree.live_children(ROOT),
            key=lambda n: ucb(n.value, n.visits, root.visits, self.config.c_plan),
        )

    def expand(self, tree: Tree, node: Node) -> bool:
        live = tree.live_children(node.id)
        return not live or should_widen(node.visits, len(node.children), self.config.widen_k)

    def pick_child(self, tree: Tree, node: Node) -> Node:
        return max(
            tree.live_children(node.id),
            key=lambda n: ucb(n.value, n.visits, node.visits, self.config.c_node),
        )

    def leaf_value(self, leaf: Node, plan: AbstractPlan) -> float:
        depth = len(plan.stream_plan)
        if leaf.success:
            return success_value([1.0] * len(plan.actions), self.config)
        return failure_value(leaf.depth - 1, depth, self.config)

    def observe(self, tree: Tree, nodes: Sequence[Node]) -> None:
        return None

    def ask_more(self, tree: Tree, plans_open: int, asked: int, ask_s: float) -> bool:
        """eTAMP's widening rule at the root, the same that opens a known plan."""
        return tree[ROOT].visits > self.config.root_widen_k * plans_open**2

    def plans_added(
        self,
        skeletons: Sequence[AbstractPlan],
        states: Sequence[Sequence[frozenset[Atom]]],
    ) -> None:
        return None

    def doubts(self, instances: frozenset[InstanceKey]) -> None:
        return None


@dataclass
class SearchResult:
    status: SearchStatus
    node_id: int | None  # the fully bound node, when solved
    plan_index: int | None
    values: dict[str, Any]  # optimistic object -> value along the solution branch
    queries: list[tuple[int, QueryResult]]  # (node made by the query, result), in order
    iterations: int
    seconds: float
    oracle_query_s: float  # wall seconds of the successful queries on the solution branch
    # CPU seconds of the search's own thread outside the stream queries: selection, a learned
    # policy's features and predictions, events. Unlike wall seconds, a busy machine's other
    # processes do not add to it.
    search_cpu_s: float = 0.0
    # Which count bound ended it ("query budget of 500 reached"); None otherwise (a deadline
    # that passed included: the caller knows the seconds it set).
    ended_by: str | None = None

    @property
    def solved(self) -> bool:
        return self.status == "solved"


def context_json(
    context: StreamContext,
    fluents: frozenset[str],
    static_context: Mapping[str, Any],
    encode: Callable[[Any], Any],
) -> dict[str, Any]:
    """What a query's ``stream_queried`` event records of the world its sampler saw
    (:func:`planner.search.queries.query_context`: the same context the models read)."""
    return query_context(
        context.state,
        context.values,
        fluents=fluents,
        static_context=static_context,
        encode=encode,
    )


@contextlib.contextmanager
def young_objects_only() -> Iterator[None]:
    """Within the block, the cyclic garbage collector leaves alone every object made before it
    (:func:`gc.freeze`; :func:`gc.unfreeze` after, so they are collected again as before).

    A run's set-up leaves millions of objects that live as long as it does (the simulator, the
    models, the problem); a full collection walks all of them, and Python starts one whenever
    enough objects have piled up, so a search paid for it at random points and its own seconds
    varied with where the collections fell. Frozen, a collection walks only the search's own
    objects. Nothing is kept longer: unreachable objects are freed by reference counting as
    usual, and the frozen ones are collectable again after the block."""
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


class TreeSearch:
    """One search over the stream plans of ``skeletons``."""

    def __init__(
        self,
        skeletons: Sequence[AbstractPlan],
        states: Sequence[Sequence[frozenset[Atom]]],
        initial_values: Mapping[str, Any],
        runtime: StreamRuntime,
        policy: Policy,
        *,
        emitter: Emitter | None = None,
        encode: Callable[[Any], Any] = repr,
        describe: Callable[[Any], str] | None = None,
        progress: Callable[[str], None] | None = None,
        should_stop: Callable[[], bool] | None = None,
        fluents: frozenset[str] = frozenset(),
        static_context: Mapping[str, Any] | None = None,
        reuse: bool = False,
        exhaustion: bool = True,
        feed: SkeletonFeed | None = None,
        fluent_streams: frozenset[str] = frozenset(),
        memo_tests: bool = True,
        doubt_after: int = 8,
        memo_exhausted: bool = True,
    ) -> None:
        if not skeletons:
            raise ValueError("the search needs at least one stream plan")
        if len(states) != len(skeletons):
            raise ValueError("one list of stream contexts per skeleton is needed")
        self.skeletons = list(skeletons)
        self.states = [list(s) for s in states]
        self.initial_values = dict(initial_values)
        self.runtime = runtime
        self.policy = policy
        self.encode = remembered(encode)  # JSON of a value, once per value object
        self.describe = describe  # a label of an encoded value, for people (events' labels)
        self.report = (  # the tree's events
            None if emitter is None else NodeEvents(emitter, encode=self.encode, describe=describe)
        )
        self.progress = progress
        self.should_stop = should_stop
        self.fluents = fluents  # predicates recorded as the context of each query
        self.static_context = dict(static_context or {})  # recorded with every query too
        # Reuse the outputs of an identical successful query (same stream, inputs and fluent
        # context) for a node's first attempt, where nothing else reads those outputs: a
        # motion re-made after an unrelated choice changed costs nothing (see _reusable).
        self.reuse = reuse
        # A node whose stream said it is exhausted (Failure.exhausted: a generator that ended,
        # a PDDLStream function that gave its one output) is not queried again; a node left
        # with nothing live below it is dead, and so is a plan whose nodes all are.
        self.exhaustion = exhaustion
        # More stream plans on demand: the root's "ask for another skeleton" (Policy.ask_more),
        # and what the search proved (self.feedback()) goes with every request.
        self.feed = feed
        # A test's answer is a function of its inputs (and, for a stream that reads fluents,
        # of its context): with memo_tests a test asked again with the same ones gets its
        # first answer back without a query (a failure as well as a success).
        self.memo_tests = memo_tests
        self.fluent_streams = fluent_streams  # streams whose samplers read the state
        # identity -> (success, the node of the first answer, whether the stream said exhausted)
        self._tests: dict[str, tuple[bool, int, bool]] = {}
        # Known failures: a stream that found nothing for some inputs and said it will not
        # (Failure.exhausted: a PDDLStream function that gave no output, a hand blocked both
        # ways round) is not asked those inputs again: with memo_exhausted the failure comes back
        # without a query and the querying node is marked (Node.known_failure), so a learned
        # policy predicts it as the failure it is. The key is the stream and its inputs, with
        # the declared fluents of a stream that has them, and the whole recorded context of
        # one whose sampler reads the state (bound with context). Why: a list of grasps starts
        # again at its first under every new node, and a model sure of that grasp's IK made
        # each fresh branch look as good as the last (pick_place_2d: 3,735 IK queries on two
        # grasps that never reach, in one timed-out run).
        self.memo_exhausted = memo_exhausted
        reads = getattr(runtime, "state_reads", None)
        self._reads_inputs: frozenset[str] = frozenset(reads() if callable(reads) else ())
        self._known: dict[str, int] = {}  # key -> the node of the first failure
        # Feedback: per stream instance of the optimistic task, its queries and successes; an
        # instance asked doubt_after times with no success is doubted (0: never).
        self.records = InstanceRecords(
            doubt_after=doubt_after, fluent_streams=fluent_streams, on_doubts=policy.doubts
        )
        self.asked = 0  # requests for more skeletons this search made
        self._reusable = [self._leaves(i) for i in range(len(self.skeletons))] if reuse else []
        # identity -> (node, outputs, wall seconds) of its first success, whether it was the
        # stream's last for those inputs and its outputs' execution seconds
        self._results: dict[str, tuple[int, tuple[Any, ...], float, bool, float]] = {}
        self.tree = Tree()
        self.queries: list[tuple[int, QueryResult]] = []
        self.deepest = 0.0  # largest share of a stream plan bound so far
        self._last_progress = 0.0
        self._plans_open = 0  # stream plans given a node under the root so far
        self._query_cpu_s = 0.0  # CPU seconds of the queries the runtime answered (this thread's)
        # What the search's bounds count (planner.search.bounds), over every run() call: the
        # queries a sampler answered (no reused answer) and the loop's iterations.
        self.answered = 0
        self.iterations = 0

    # --- steps: a search is these two, in the order its policy picks (:meth:`run`); a caller
    # may also take them by hand, as the tests do ----------------------------------------------

    def open_plan(self, index: int) -> Node:
        """Open skeleton ``index``: a new child of the root, with nothing bound yet."""
        node = self.tree.add(ROOT, plan_index=index, depth=0, success=True)
        self._plans_open += 1
        if self.report is not None:
            self.report.plan_opened(node.id, index, len(self.skeletons[index].stream_plan))
        return node

    def _leaves(self, plan_index: int) -> list[bool]:
        return reusable_streams(self.skeletons[plan_index], self.states[plan_index], self.fluents)

    def _identity(self, stream: str, inputs: tuple[Any, ...], context: StreamContext) -> str:
        encoded = [self.encode(v) for v in inputs]
        return query_identity(stream, encoded, self._context_json(context))

    def query(self, node: Node) -> Node:
        """Query the next stream of ``node``'s plan once; the result becomes a child."""
        plan = self.skeletons[node.plan_index]
        inst = plan.stream_plan[node.depth]
        values = {**self.initial_values, **self.tree.bindings(node.id)}
        inputs = tuple(values[name] for name in inst.inputs)
        context = StreamContext(self.states[node.plan_index][node.depth], values)
        identity = None
        if self.reuse and self._reusable[node.plan_index][node.depth]:
            identity = self._identity(inst.stream, inputs, context)
        earlier = self._results.get(identity) if identity and not node.children else None
        reused_from: int | None = None
        wall_s = 0.0  # what the node's binding cost, for the oracle: the original's seconds
        test_key = self._test_key(inst, inputs, context)
        answered = self._tests.get(test_key) if test_key is not None else None
        known_key = self._known_key(inst, inputs, context)
        known = self._known.get(known_key) if known_key is not None else None
        if known is not None:
            reused_from = known
            node.known_failure = True
            result = QueryResult(
                inst.stream,
                None,
                0.0,
                0.0,
                reused=True,
                exhausted=True,
                reason="the stream found nothing for these inputs before (and said it will not)",
            )
        elif answered is not None:
            success, reused_from, exhausted = answered
            result = QueryResult(
                inst.stream,
                () if success else None,
                0.0,
                0.0,
                reused=True,
                exhausted=exhausted,  # as the stream said the first time
                reason=None if success else "the same test failed on these inputs before",
            )
        elif earlier is not None:
            reused_from, outputs_, wall_s, last, moves = earlier
            result = QueryResult(
                inst.stream, outputs_, 0.0, 0.0, reused=True, exhausted=last, duration_s=moves
            )
        else:
            result = self.runtime.query(
                inst.stream, inputs, key=(node.id, inst.stream), context=context
            )
            self.answered += 1
            self._query_cpu_s += result.cpu_s  # this thread's: the runtime's clock
        outputs = (
            dict(zip(inst.outputs, result.outputs, strict=True))
            if result.outputs is not None
            else {}
        )
        child = self.tree.add(
            node.id,
            plan_index=node.plan_index,
            depth=node.depth + 1,
            success=result.success,
            outputs=outputs,
            query_wall_s=wall_s if result.reused else result.wall_s,
            execution_s=result.execution_s if result.success else 0.0,
        )
        self.queries.append((child.id, result))
        if result.exhausted and self.exhaustion:
            node.exhausted = True
        if test_key is not None and answered is None and result.error is None:
            self._tests[test_key] = (result.success, child.id, result.exhausted)
        if (
            known_key is not None
            and known is None
            and not result.success
            and result.exhausted
            and result.error is None
        ):
            self._known.setdefault(known_key, child.id)
        if not result.reused:  # an answer given again is no new evidence
            self.records.record(inst, result)
        if identity is not None and result.outputs is not None and reused_from is None:
            self._results.setdefault(
                identity,
                (
                    child.id,
                    tuple(result.outputs),
                    result.wall_s,
                    result.exhausted,
                    result.execution_s,
                ),
            )
        if result.success:
            self.deepest = max(self.deepest, child.depth / len(plan.stream_plan))
        if self.report is not None:
            self.report.queried(
                node_id=child.id,
                parent_id=node.id,
                plan_index=child.plan_index,
                depth=child.depth,
                inst=inst,
                inputs=inputs,
                context=self._context_json(context),
                result=result,
                reused_from=reused_from,
            )
        return child

    def _test_key(
        self, inst: StreamInstance, inputs: tuple[Any, ...], context: StreamContext
    ) -> str | None:
        """The memo key of a test query (None: not a memoized test): its stream and encoded
        inputs, and its context when the stream reads fluents."""
        if not self.memo_tests or inst.outputs or inst.kind != "stream":
            return None
        if inst.stream in self.fluent_streams:
            return self._identity(inst.stream, inputs, context)
        return query_identity(inst.stream, [self.encode(v) for v in inputs], {})

    def _known_key(
        self, inst: StreamInstance, inputs: tuple[Any, ...], context: StreamContext
    ) -> str | None:
        """The key of a stream query among the known failures (None: not remembered): its
        stream and encoded inputs, with its declared fluents' context, or with the whole
        recorded context when its sampler reads the state."""
        if not self.memo_exhausted or not inst.outputs or inst.kind != "stream":
            return None
        if inst.stream in self._reads_inputs and inst.stream not in self.fluent_streams:
            return query_identity(inst.stream, [self.encode(v) for v in inputs], {})
        return self._identity(inst.stream, inputs, context)

    def feedback(self) -> Feedback:
        """What the queries so far proved about the optimistic task
        (:meth:`planner.search.feedback.InstanceRecords.feedback`)."""
        return self.records.feedback()

    def add_skeletons(
        self, plans: Sequence[tuple[AbstractPlan, Sequence[frozenset[Atom]]]]
    ) -> None:
        """More stream plans for the root to open (from the feed, or by hand in tests)."""
        for plan, states in plans:
            self.skeletons.append(plan)
            self.states.append(list(states))
            if self.reuse:
                self._reusable.append(self._leaves(len(self.skeletons) - 1))
        self.policy.plans_added(self.skeletons, self.states)

    def _ask(self, reason: str) -> int:
        """Ask the feed for more stream plans; how many came."""
        assert self.feed is not None
        self.asked += 1
        found = self.feed.more(reason, self.feedback())
        self.add_skeletons(found)
        return len(found)

    def _can_ask(self) -> bool:
        return self.feed is not None and not self.feed.exhausted_for(self.feedback())

    def _context_json(self, context: StreamContext) -> dict[str, Any]:
        return context_json(context, self.fluents, self.static_context, self.encode)

    def _wants_more(self, tree: Tree) -> bool:
        assert self.feed is not None
        requests = max(self.feed.requests, 1)
        return self.policy.ask_more(
            tree, self._plans_open, self.asked, self.feed.seconds / requests
        )

    def _bury(self, node: Node) -> None:
        """``node`` is exhausted and nothing live is below it: it is dead, and so is each
        ancestor left the same way (a plan node's parent, the root, stays)."""
        current: Node | None = node
        while current is not None and current.id != ROOT:
            if not current.exhausted or self.tree.live_children(current.id):
                return
            current.dead = True
            current = None if current.parent is None else self.tree[current.parent]

    def _complete(self, node: Node) -> bool:
        return node.success and node.depth == len(self.skeletons[node.plan_index].stream_plan)

    def _backup(self, leaf: Node) -> None:
        plan = self.skeletons[leaf.plan_index]
        leaf.value = self.policy.leaf_value(leaf, plan)
        current: int | None = leaf.id
        while current is not None:
            node = self.tree[current]
            node.visits += 1
            if node.id != leaf.id:
                visited = [self.tree[c].value for c in node.children if self.tree[c].visits]
                node.value = max(visited) if visited else 0.0
            if self.report is not None:
                self.report.visited(node.id, node.visits, node.value)
            current = node.parent

    def _say(self, start: float) -> None:
        if self.progress is None:
            return
        now = time.perf_counter()
        if now - self._last_progress < 0.2:
            return
        self._last_progress = now
        self.progress(
            f"queries {len(self.queries)}, nodes {len(self.tree)}, deepest binding "
            f"{self.deepest:.0%}, {now - start:.0f} s"
        )

    # --- the loop ----------------------------------------------------------------------------

    def run(
        self,
        *,
        deadline: float,
        start: float | None = None,
        bounds: SearchBounds | None = None,
    ) -> SearchResult:
        """Search until a plan is fully bound, ``deadline`` (perf_counter) passes, one of
        ``bounds`` is reached (queries a sampler answered, iterations: counted over every call,
        status ``timeout`` and ``ended_by`` saying which), or stop. A second call goes on with
        the same tree (no stream plan is opened twice).

        While it runs, Python's cyclic garbage collector leaves alone the objects that existed
        before (:func:`young_objects_only`)."""
        with young_objects_only():
            return self._run(deadline=deadline, start=start, bounds=bounds or SearchBounds())

    def _run(self, *, deadline: float, start: float | None, bounds: SearchBounds) -> SearchResult:
        start = time.perf_counter() if start is None else start
        cpu_start, query_cpu_start = time.thread_time(), self._query_cpu_s
        first = min(self.policy.initial_plans(len(self.skeletons)), len(self.skeletons))
        while self._plans_open < first:
            self.open_plan(self._plans_open)
        iterations = 0
        status: SearchStatus = "timeout"
        ended_by: str | None = None
        solution: Node | None = None
        while True:
            if time.perf_counter() >= deadline:
                status = "timeout"
                break
            if self.should_stop is not None and self.should_stop():
                status = "cancelled"
                break
            ended_by = bounds.reached(self.answered, self.iterations)
            if ended_by is not None:
                status = "timeout"
                break
            iterations += 1
            self.iterations += 1
            tree = self.tree
            closed = self._plans_open < len(self.skeletons)
            live = tree.live_children(ROOT)
            if closed and (
                self.policy.add_plan(tree, self._plans_open, len(self.skeletons)) or not live
            ):
                node = self.open_plan(self._plans_open)
            elif not closed and self._can_ask() and (not live or self._wants_more(tree)):
                if self._ask("more" if live else "all dead") == 0 and not live:
                    continue  # nothing new: the next iteration finds the source exhausted
                continue  # the next iteration opens what came (or goes on with the open ones)
            elif not live:
                status = "failed"  # every stream plan is exhausted, and nothing more comes
                break
            else:
                node = self.policy.pick_plan(tree)
            made = len(tree.nodes)
            leaf: Node | None = None
            while leaf is None:
                if self._complete(node):
                    leaf = node
                elif node.exhausted and not tree.live_children(node.id):
                    self._bury(node)  # nothing to do here: the next iteration goes elsewhere
                    break
                elif not node.exhausted and self.policy.expand(tree, node):
                    child = self.query(node)
                    while child.success and not self._complete(child):
                        if time.perf_counter() >= deadline or bounds.queries_reached(self.answered):
                            break
                        child = self.query(child)  # simulation: bind what follows once
                    leaf = child
                else:
                    node = self.policy.pick_child(tree, node)
            if leaf is None:
                continue  # a node was found dead; the next iteration chooses again
            self._backup(leaf)
            self.policy.observe(tree, tree.nodes[made:])
            self._say(start)
            if self._complete(leaf):
                solution = leaf
                status = "solved"
                break
        seconds = time.perf_counter() - start
        own_cpu = time.thread_time() - cpu_start - (self._query_cpu_s - query_cpu_start)
        if solution is None:
            return SearchResult(
                status,
                None,
                None,
                {},
                self.queries,
                iterations,
                seconds,
                0.0,
                max(own_cpu, 0.0),
                ended_by,
            )
        branch = set(self.tree.path(solution.id))
        oracle = sum(self.tree[i].query_wall_s for i in branch)
        execution = sum(r.execution_s for node_id, r in self.queries if node_id in branch)
        values = self.tree.bindings(solution.id)
        if self.report is not None:
            self.report.solved(
                solution.id,
                solution.plan_index,
                planning_s=seconds,
                execution_s=execution,
                oracle_s=oracle,
            )
        return SearchResult(
            "solved",
            solution.id,
            solution.plan_index,
            values,
            self.queries,
            iterations,
            seconds,
            oracle,
            max(own_cpu, 0.0),
        )
