"""Two runs side by side: their search trees, where their seconds went, their stream queries,
their progress in time, and the first point where the two searches chose differently.

A run's tree is read from its stored events (``node_added``, ``model_prediction``,
``solution_found``, ``abstract_plans_found``, ``stream_queried``) without building event
objects, into columns the page draws directly (:class:`Tree`); a finished run's tree is kept
while the server runs. The time split and the query table are :mod:`planner.report`'s, the
same code as ``tamp report``.

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
from planner.report import query_summary, run_time_split
from planner.store import LIVE_STATUSES, QueryOutcome, RunRecord, RunStore

# The events a tree is read from; the queries' times come from their rows
# (RunStore.query_times), so the queries' events, half a tree's bytes, are not parsed.
TREE_TYPES = (
    "abstract_plans_found",
    "skeletons_added",
    "node_added",
    "model_prediction",
    "solution_found",
)
MAX_CURVE_POINTS = 1000  # points of a run's queries-against-seconds curve
KEPT_TREES = 8  # finished runs' trees kept in memory
KEPT_COMPARISONS = 8  # comparisons of two finished runs kept in memory


@dataclass(frozen=True)
class Tree:
    """One run's search tree in columns, in the order the nodes were made (the root first)."""

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
    query_t: list[float]  # t of each query a sampler answered (reused ones left out)
    plans_t: float = 0.0  # t of abstract_plans_found: the skeleton source's first seconds
    later_skeletons_s: float = 0.0  # seconds of the skeletons the search asked for after

    @property
    def size(self) -> int:
        return len(self.ids)


def read_tree(store: RunStore, run_id: str) -> Tree:
    """KeyError for an unknown run."""
    events = store.events_of(run_id, TREE_TYPES)
    ids: list[int] = []
    parents: list[int | None] = []
    plans: list[int] = []
    depths: list[int] = []
    streams: list[int] = []
    success: list[bool] = []
    labels: list[str] = []
    names: dict[str, int] = {}
    q: dict[int, float] = {}
    solution: int | None = None
    plan_list: list[dict[str, Any]] = []
    query_t = store.query_times(run_id)
    plans_t: float | None = None
    later = 0.0
    root, root_label = 0, "root"  # the search does not announce its root; a test may
    for e in events:
        kind = e["type"]
        if kind == "node_added" and e.get("parent_id") is None:
            root, root_label = int(e["node_id"]), str(e.get("label") or "root")
        elif kind == "node_added":
            stream = e.get("stream")
            ids.append(int(e["node_id"]))
            parents.append(int(e["parent_id"]))
            plans.append(int(e.get("plan_index", -1)))
            depths.append(int(e.get("depth", 0)))
            streams.append(-1 if stream is None else names.setdefault(str(stream), len(names)))
            success.append(bool(e.get("success", True)))
            labels.append(str(e.get("label", "")))
        elif kind == "model_prediction":
            q[int(e["node_id"])] = float(e["q"])
        elif kind == "solution_found":
            solution = int(e["node_id"])
        elif kind == "abstract_plans_found" and plans_t is None:
            plan_list = list(e.get("plans", []))
            plans_t = float(e["t"])
        elif kind == "skeletons_added":  # more skeletons during the search, indices following
            plan_list += list(e.get("plans", []))
            later += float(e.get("seconds", 0.0))
    ids.insert(0, root)  # the root first: node i > 0 is the i-th node made
    return Tree(
        run_id=run_id,
        ids=ids,
        parents=[None, *parents],
        plans=[-1, *plans],
        depths=[0, *depths],
        streams=[-1, *streams],
        stream_names=list(names),
        success=[True, *success],
        q=[q.get(i) for i in ids],
        labels=[root_label, *labels],
        solution=solution,
        plan_list=plan_list,
        query_t=query_t,
        plans_t=plans_t or 0.0,
        later_skeletons_s=later,
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
    actions = {
        int(p.get("index", i)): tuple(p.get("actions", ())) for i, p in enumerate(tree.plan_list)
    }
    for i, node in enumerate(tree.ids):
        parent = tree.parents[i]
        if parent is None:
            key_of[node] = intern.setdefault(("root",), len(intern))
            continue
        parent_key = key_of.get(parent, intern.setdefault(("unseen", parent), len(intern)))
        ordinal = children.get(parent, 0)
        children[parent] = ordinal + 1
        if tree.streams[i] < 0:  # a stream plan: which plan it is
            plan = tree.plans[i]
            local: tuple[Any, ...] = ("plan", actions.get(plan, ("#", plan)))
        else:
            local = (tree.stream_names[tree.streams[i]], ordinal)
        key = intern.setdefault((parent_key, local), len(intern))
        key_of[node] = key
        out.append(key)
    return out


def _node(tree: Tree, i: int) -> dict[str, Any]:
    """Node ``i`` (an index into the tree's columns) as the page names it."""
    parent = tree.parents[i]
    stream = tree.stream_names[tree.streams[i]] if tree.streams[i] >= 0 else None
    return {
        "node_id": tree.ids[i],
        "parent_id": parent,
        "plan_index": tree.plans[i],
        "depth": tree.depths[i],
        "stream": stream,
        "success": tree.success[i],
        "label": tree.labels[i],
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
    return [p.get("actions") for p in tree.plan_list]


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
    n = min(len(keys_a), len(keys_b))
    same = next((i for i in range(n) if keys_a[i] != keys_b[i]), n)
    outcome = None
    for i in range(same):
        if a.success[i + 1] != b.success[i + 1]:
            na, nb = _node(a, i + 1), _node(b, i + 1)
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
        node = _node(longer, same + 1)
        text = (
            f"the two searches made the same {_nodes(same)}; then only {name} went on: "
            + _describe(name, node)
        )
        kind = "prefix"
        node_a = node if longer is a else None
        node_b = node if longer is b else None
    else:
        node_a, node_b = _node(a, same + 1), _node(b, same + 1)
        text = (
            f"after {_nodes(same)} made alike, {_describe(name_a, node_a)}, while "
            f"{_describe(name_b, node_b)}"
        )
        kind = "choice"
    if plans_differ:
        text += (
            f"; the top-k planner gave them different abstract plans ({len(a.plan_list)} and "
            f"{len(b.plan_list)})"
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
    return figures.q_scale(q for tree in trees for q in tree.q if q is not None)


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
    split = run_time_split(planning, plans_at, outcomes, search_cpu_s, tree.later_skeletons_s)
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
