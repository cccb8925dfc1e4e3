"""Two runs side by side: their search trees, where their seconds went, their stream queries,
their progress in time, and the first point where the two searches chose differently.

A run's tree is :mod:`planner.trace`'s fold of its stored events (``node_added``,
``model_prediction``, ``solution_found``, ``abstract_plans_found``, ``skeletons_added``: not
the queries' events, half a tree's bytes), served to the page in columns it draws directly
(:class:`Columns`); a finished run's tree is kept while the server runs. The time split and
the query table are :mod:`planner.report`'s, the same code as ``tamp report``.

Where two searches part: every node gets a key that says which choice made it, without its
sampled values (those differ whenever the samplers' random draws do): a stream plan is its
actions; a node below it is the k-th query of its parent's stream. Two runs chose alike as long
as their nodes, in the order they were made, have the same keys; the first node whose keys
differ is where they chose differently. A query both made alike whose outcome differed (one
succeeded, the other failed) is reported too: it is often why the choices part.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from planner import figures
from planner.events import (
    AbstractPlansFound,
    ModelPrediction,
    NodeAdded,
    SkeletonsAdded,
    SolutionFound,
)
from planner.report import query_summary, run_time_split
from planner.status import LIVE_STATUSES
from planner.store import QueryOutcome, RunRecord, RunStore
from planner.trace import Trace, TraceNode, fold

# The events a tree is read from; the queries' times come from their rows
# (RunStore.query_times), so the queries' events, half a tree's bytes, are not parsed.
TREE_TYPES = tuple(
    c.type for c in (AbstractPlansFound, SkeletonsAdded, NodeAdded, ModelPrediction, SolutionFound)
)
MAX_CURVE_POINTS = 1000  # points of a run's queries-against-seconds curve
KEPT_TREES = 8  # finished runs' trees kept in memory
KEPT_COMPARISONS = 8  # comparisons of two finished runs kept in memory


@dataclass(frozen=True)
class Tree:
    """One run's search tree (:class:`planner.trace.Trace`) and when its queries were made."""

    run_id: str
    trace: Trace
    query_t: list[float]  # t of each query a sampler answered (reused ones left out)

    @property
    def size(self) -> int:
        """Nodes, the root included."""
        return len(self.trace)

    @property
    def plans_t(self) -> float:
        """t of abstract_plans_found: the skeleton source's first seconds (0: none yet)."""
        return self.trace.plans_t or 0.0


@dataclass(frozen=True)
class Columns:
    """A tree in columns, in the order the nodes were made (the root first): what the page's
    compare view draws (GET /api/runs/{id}/tree)."""

    run_id: str
    ids: list[int]
    parents: list[int | None]
    plans: list[int]
    depths: list[int]
    streams: list[int]  # index into stream_names; -1: root or a stream plan
    stream_names: list[str]
    success: list[bool]
    q: list[float | None]  # the latest model prediction's Q; None without one
    labels: list[str]
    solution: int | None
    plan_list: list[dict[str, Any]]  # abstract_plans_found's plans, then skeletons_added's


def read_tree(store: RunStore, run_id: str) -> Tree:
    """KeyError for an unknown run."""
    return Tree(run_id, fold(store.events_of(run_id, TREE_TYPES)), store.query_times(run_id))


def columns(tree: Tree) -> Columns:
    nodes = tree.trace.ordered()
    names: dict[str, int] = {}
    solution = tree.trace.solution
    return Columns(
        run_id=tree.run_id,
        ids=[n.id for n in nodes],
        parents=[n.parent for n in nodes],
        plans=[n.plan_index for n in nodes],
        depths=[n.depth for n in nodes],
        streams=[-1 if n.stream is None else names.setdefault(n.stream, len(names)) for n in nodes],
        stream_names=list(names),
        success=[n.success for n in nodes],
        q=[n.q for n in nodes],
        labels=[n.label for n in nodes],
        solution=None if solution is None else solution.node_id,
        plan_list=tree.trace.plans,
    )


class Trees:
    """Trees of runs, the finished ones kept (a live run's tree is read every time). The
    compare view asks for the same two trees three times at once (``/api/compare`` and each
    ``/api/runs/{id}/tree``): concurrent misses of one tree wait for the first one's read."""

    def __init__(self, store: RunStore, keep: int = KEPT_TREES) -> None:
        self.store = store
        self.keep = keep
        self._lock = threading.Lock()
        self._kept: OrderedDict[tuple[str, int], Tree] = OrderedDict()
        self._reading: dict[tuple[str, int], threading.Lock] = {}
        self._compared: OrderedDict[tuple[Any, ...], dict[str, Any]] = OrderedDict()

    def compared(self, key: tuple[Any, ...]) -> dict[str, Any] | None:
        """A comparison kept under ``key`` (two finished runs and their last seqs)."""
        with self._lock:
            kept = self._compared.get(key)
            if kept is not None:
                self._compared.move_to_end(key)
            return kept

    def keep_compared(self, key: tuple[Any, ...], data: dict[str, Any]) -> None:
        with self._lock:
            self._compared[key] = data
            while len(self._compared) > KEPT_COMPARISONS:
                self._compared.popitem(last=False)

    def get(self, run_id: str) -> Tree:
        record = self.store.get_run(run_id)  # KeyError for an unknown run
        if record.status in LIVE_STATUSES:
            return read_tree(self.store, run_id)
        key = (run_id, self.store.last_seq(run_id))
        with self._lock:
            kept = self._kept.get(key)
            if kept is not None:
                self._kept.move_to_end(key)
                return kept
            reading = self._reading.setdefault(key, threading.Lock())
        with reading:  # the first reads; the others wait and find it kept
            with self._lock:
                kept = self._kept.get(key)
            if kept is not None:
                return kept
            try:
                tree = read_tree(self.store, run_id)
                with self._lock:
                    self._kept[key] = tree
                    while len(self._kept) > self.keep:
                        self._kept.popitem(last=False)
            finally:
                with self._lock:
                    self._reading.pop(key, None)
        return tree


# --- where the searches part ---------------------------------------------------------------------


def choice_keys(tree: Tree, intern: dict[tuple[Any, ...], int]) -> list[int]:
    """The key of every node but the root, in the order made (``intern`` shared between the
    trees compared, so equal keys are equal numbers)."""
    key_of: dict[int, int] = {}
    children: dict[int, int] = {}
    out: list[int] = []
    actions = {int(p["index"]): tuple(p["actions"]) for p in tree.trace.plans}
    for node in tree.trace.ordered():
        if node.parent is None:
            key_of[node.id] = intern.setdefault(("root",), len(intern))
            continue
        parent_key = key_of[node.parent]  # the fold has every parent before its children
        ordinal = children.get(node.parent, 0)
        children[node.parent] = ordinal + 1
        if node.stream is None:  # a stream plan: which plan it is
            local: tuple[Any, ...] = ("plan", actions.get(node.plan_index, ("#", node.plan_index)))
        else:
            local = (node.stream, ordinal)
        key = intern.setdefault((parent_key, local), len(intern))
        key_of[node.id] = key
        out.append(key)
    return out


def _node(node: TraceNode) -> dict[str, Any]:
    """A node as the page names it."""
    return {
        "node_id": node.id,
        "parent_id": node.parent,
        "plan_index": node.plan_index,
        "depth": node.depth,
        "stream": node.stream,
        "success": node.success,
        "label": node.label,
    }


def _describe(name: str, node: Mapping[str, Any]) -> str:
    if node["stream"] is None:
        return f"{name} opened stream plan {node['plan_index']} (node {node['node_id']})"
    return (
        f"{name} queried {node['stream']} below node {node['parent_id']} (plan "
        f"{node['plan_index']}, depth {node['depth']}), making node {node['node_id']}"
    )


def _nodes(n: int) -> str:
    return f"{n} node" if n == 1 else f"{n} nodes"


def _actions(tree: Tree) -> list[Any]:
    return [p["actions"] for p in tree.trace.plans]


def divergence(a: Tree, b: Tree, name_a: str = "A", name_b: str = "B") -> dict[str, Any]:
    """The first point where the two searches chose differently, and the first query they
    made alike with another outcome (docstring of the module)."""
    if a.size <= 1 or b.size <= 1:
        missing = " and ".join(n for n, t in ((name_a, a), (name_b, b)) if t.size <= 1)
        return {
            "kind": "no tree",
            "same": 0,
            "text": f"{missing} reported no search tree (the sequential planner reports none)",
            "a": None,
            "b": None,
            "outcome": None,
        }
    intern: dict[tuple[Any, ...], int] = {}
    keys_a, keys_b = choice_keys(a, intern), choice_keys(b, intern)
    nodes_a, nodes_b = a.trace.ordered(), b.trace.ordered()
    n = min(len(keys_a), len(keys_b))
    same = next((i for i in range(n) if keys_a[i] != keys_b[i]), n)
    outcome = None
    for i in range(same):
        if nodes_a[i + 1].success != nodes_b[i + 1].success:
            na, nb = _node(nodes_a[i + 1]), _node(nodes_b[i + 1])
            outcome = {
                "index": i,
                "a": na,
                "b": nb,
                "text": f"the same query ({na['stream']}, node {na['node_id']} / "
                f"{nb['node_id']}) {'succeeded' if na['success'] else 'failed'} in {name_a} and "
                f"{'succeeded' if nb['success'] else 'failed'} in {name_b}",
            }
            break
    plans_differ = _actions(a) != _actions(b)
    if same == len(keys_a) == len(keys_b):
        text = f"the two searches made the same {_nodes(same)} in the same order"
        kind, node_a, node_b = "identical", None, None
    elif same == n:
        longer, name = (a, name_a) if len(keys_a) > len(keys_b) else (b, name_b)
        node = _node((nodes_a if longer is a else nodes_b)[same + 1])
        text = (
            f"the two searches made the same {_nodes(same)}; then only {name} went on: "
            + _describe(name, node)
        )
        kind = "prefix"
        node_a = node if longer is a else None
        node_b = node if longer is b else None
    else:
        node_a, node_b = _node(nodes_a[same + 1]), _node(nodes_b[same + 1])
        text = (
            f"after {_nodes(same)} made alike, {_describe(name_a, node_a)}, while "
            f"{_describe(name_b, node_b)}"
        )
        kind = "choice"
    if plans_differ:
        text += (
            f"; the top-k planner gave them different abstract plans ({len(a.trace.plans)} and "
            f"{len(b.trace.plans)})"
        )
    return {
        "kind": kind,
        "same": same,
        "text": text,
        "a": node_a,
        "b": node_b,
        "outcome": outcome,
    }


# --- figures of one run ----------------------------------------------------------------------


def curve(tree: Tree, limit: int = MAX_CURVE_POINTS) -> dict[str, list[float]]:
    """Queries made against seconds since the run's start (at most ``limit`` points, the
    last one kept)."""
    t = tree.query_t
    if not t:
        return {"t": [], "queries": []}
    step = max(1, -(-len(t) // limit))
    picked = list(range(step - 1, len(t), step))
    if picked[-1] != len(t) - 1:
        picked.append(len(t) - 1)
    return {"t": [0.0] + [t[i] for i in picked], "queries": [0.0] + [float(i + 1) for i in picked]}


def q_scale(trees: Sequence[Tree]) -> tuple[float, float] | None:
    """One colour scale for several trees (:func:`planner.figures.q_scale` of every predicted
    Q in them: the page's own scale, over both)."""
    return figures.q_scale(q for tree in trees for q in tree.trace.predictions().values())


def time_split(
    record: RunRecord,
    tree: Tree,
    outcomes: Sequence[QueryOutcome],
    search_cpu_s: float | None = None,
) -> dict[str, Any]:
    """:func:`planner.report.run_time_split` of one run, with its execution seconds; a run
    still going counts its planning seconds so far."""
    plans_at = tree.plans_t  # what store.event_times(..., "abstract_plans_found") reads
    planning = record.planning_s
    if planning is None:
        planning = max([plans_at, *tree.query_t[-1:]])
    split = run_time_split(planning, plans_at, outcomes, search_cpu_s, tree.trace.later_skeletons_s)
    return {
        **split,
        "execution_s": record.execution_s,
        "so_far": record.status in LIVE_STATUSES,
    }


def notes(a: RunRecord, b: RunRecord) -> list[str]:
    """What a reader must know before comparing the two runs."""
    out = []
    if a.scene != b.scene or a.config.get("domain") != b.config.get("domain"):
        out.append(
            f"different scenes ({a.scene} and {b.scene}): the two searches solve different problems"
        )
    elif a.seed != b.seed:
        out.append(
            f"different seeds ({a.seed} and {b.seed}): the scene's random parts and the samplers' "
            "draws differ"
        )
    if a.id == b.id:
        out.append("the same run twice")
    for r in (a, b):
        if r.status in LIVE_STATUSES:
            out.append(f"run {r.id[:8]} is still {r.status}: its figures are so far")
    return out


def compare_runs(store: RunStore, trees: Trees, a_id: str, b_id: str) -> dict[str, Any]:
    """Everything the compare view shows of runs ``a_id`` and ``b_id``; KeyError names a run
    that does not exist."""
    records = {}
    for run_id in (a_id, b_id):
        try:
            records[run_id] = store.get_run(run_id)
        except KeyError as exc:
            raise KeyError(f"unknown run {run_id!r}") from exc
    a, b = records[a_id], records[b_id]
    finished = a.status not in LIVE_STATUSES and b.status not in LIVE_STATUSES
    key = (a_id, store.last_seq(a_id), b_id, store.last_seq(b_id))
    if finished and (kept := trees.compared(key)) is not None:
        return kept  # two finished runs do not change (the page asks again on every visit)
    tree_a, tree_b = trees.get(a_id), trees.get(b_id)

    def side(record: RunRecord, tree: Tree) -> dict[str, Any]:
        outcomes = store.query_outcomes([record.id])
        return {
            "run": record,
            "nodes": tree.size,
            "split": time_split(
                record,
                tree,
                outcomes,
                store.event_numbers([record.id], "run_finished", "search_cpu_s").get(record.id),
            ),
            # the run's queries per stream: how many failed and why (tamp report's)
            "queries": query_summary(outcomes),
            "curve": curve(tree),
        }

    name_a, name_b = f"A ({a.planner})", f"B ({b.planner})"
    data = {
        "a": side(a, tree_a),
        "b": side(b, tree_b),
        "same_scene": a.scene == b.scene and a.config.get("domain") == b.config.get("domain"),
        "notes": notes(a, b),
        "divergence": divergence(tree_a, tree_b, name_a, name_b),
        "q_scale": q_scale([tree_a, tree_b]),
    }
    if finished:
        trees.keep_compared(key, data)
    return data
