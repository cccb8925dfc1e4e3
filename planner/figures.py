"""One definition of each figure that several views of a run show, so that they agree.

The dashboard's page (``static/``), its 3D view (``app/viewer.py``), the compare view
(``app/compare.py``) and the benchmark reports (:mod:`planner.report`) all show these; the page
reads them from ``/generated/definitions.js``, which :func:`definitions` makes (never a copy in
JavaScript):

- **Names**: of every event type (:mod:`planner.events`) and of every status, a run's, a
  benchmark's and a training job's (:mod:`planner.status`, with one line for each run
  status), as ``EVENT.NODE_ADDED`` and ``STATUS.RUNNING`` on the page: its fold of events
  (``static/tree.js``) and its checks of statuses use these, never literals.
- **Stream queries**: a ``stream_queried`` event is one of three kinds. ``ok`` and ``failed``
  are queries a sampler answered; ``reused`` is an answer taken from an identical earlier query
  (``reused_from``), for which no sampler ran. "Queries" means the first two (what the planner's
  ``run_finished.queries``, the run's row and the store's query rows count); reused answers are
  counted apart.
- **The colour scale of the predicted cost Q** (the learned planner's ``model_prediction``):
  green (low) through yellow to red (high) between two percentiles of the Q values predicted in
  the tree, nearest rank (one outlier, a ``P_S`` near 0, must not wash the others out). A node
  without a prediction of its own (one made in a simulation) takes its nearest predicted
  ancestor's Q, the cost the planner expected when it went down that branch; grey when there is
  none above it either (the baseline planner predicts nothing).
- **Intervals**: a bootstrap interval over fewer than :data:`MIN_INTERVAL_SEEDS` seeds says so.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from planner.events import EVENT_TYPES, StreamQueried
from planner.status import (
    BENCH_STATUSES,
    LIVE_STATUSES,
    RUN_STATUSES,
    STATUS_TEXT,
    TRAIN_STATUSES,
    all_status_names,
)

# --- run statuses ------------------------------------------------------------------------------

# The names and their lines are planner.status's; the page reads them from here.

# --- stream queries ----------------------------------------------------------------------------

QUERY_KINDS: tuple[str, ...] = ("ok", "failed", "reused")
QUERY_KIND_TEXT: dict[str, str] = {
    "ok": "a sampler answered with a value",
    "failed": "a sampler answered nothing (or raised)",
    "reused": "the answer of an identical earlier query; no sampler ran (not counted as a query)",
}
QUERY_KIND_RGB: dict[str, tuple[int, int, int]] = {
    "ok": (22, 163, 74),
    "failed": (220, 38, 38),
    "reused": (148, 163, 184),
}


def query_kind(event: Mapping[str, Any]) -> str:
    """``ok``, ``failed`` or ``reused``: the kind of one ``stream_queried`` event (a dict as
    :func:`planner.events.event_to_dict` makes it)."""
    if event.get("reused_from") is not None:
        return "reused"
    return "ok" if event.get("success") else "failed"


@dataclass
class QueryCount:
    """One stream's queries: ``ok`` and ``failed`` ran a sampler; ``reused`` did not."""

    ok: int = 0
    failed: int = 0
    reused: int = 0

    @property
    def queries(self) -> int:
        """Queries a sampler answered (reused answers apart)."""
        return self.ok + self.failed


def count_queries(events: Iterable[Mapping[str, Any]]) -> dict[str, QueryCount]:
    """Stream -> its :class:`QueryCount`, from a run's events (other types are skipped)."""
    out: dict[str, QueryCount] = {}
    for e in events:
        if e.get("type") != StreamQueried.type:
            continue
        count = out.setdefault(str(e["stream"]), QueryCount())
        kind = query_kind(e)
        setattr(count, kind, getattr(count, kind) + 1)
    return out


# --- the colour scale of Q ---------------------------------------------------------------------

Q_PERCENTILES = (2.0, 98.0)  # green and red are these percentiles (nearest rank) of Q
# Green, light green, yellow, orange, red: Q from low to high (ColorBrewer's RdYlGn, reversed).
Q_STOPS: tuple[tuple[int, int, int], ...] = (
    (26, 152, 80),
    (166, 217, 106),
    (254, 224, 139),
    (244, 109, 67),
    (215, 48, 39),
)
NO_PREDICTION_RGB = (154, 163, 174)  # grey: no prediction for the node nor above it
Q_INHERITED = True  # a node without a prediction of its own takes its nearest ancestor's Q


def q_scale(values: Iterable[float]) -> tuple[float, float] | None:
    """``(lo, hi)``: the :data:`Q_PERCENTILES` of the predicted Q values, nearest rank (the
    page computes exactly this: ``sorted[floor(0.02 (n - 1))]``, ``sorted[ceil(0.98 (n -
    1))]``); None without any."""
    qs = sorted(float(q) for q in values)
    if not qs:
        return None
    n = len(qs)
    lo = qs[math.floor(Q_PERCENTILES[0] / 100 * (n - 1))]
    hi = qs[math.ceil(Q_PERCENTILES[1] / 100 * (n - 1))]
    return lo, hi


def q_fraction(q: float, lo: float, hi: float) -> float:
    """Where ``q`` is on the scale ``lo..hi``: 0 green, 1 red (clamped; 0 when lo == hi)."""
    if hi <= lo:
        return 0.0
    return min(max((q - lo) / (hi - lo), 0.0), 1.0)


def q_rgb_at(fraction: float) -> tuple[int, int, int]:
    """The colour at ``fraction`` (0 green .. 1 red) along :data:`Q_STOPS`."""
    pos = min(max(fraction, 0.0), 1.0) * (len(Q_STOPS) - 1)
    i = min(int(pos), len(Q_STOPS) - 2)
    u = pos - i
    a, b = Q_STOPS[i], Q_STOPS[i + 1]
    return (
        round(a[0] + (b[0] - a[0]) * u),
        round(a[1] + (b[1] - a[1]) * u),
        round(a[2] + (b[2] - a[2]) * u),
    )


def effective_q(
    parents: Mapping[int, int | None], own: Mapping[int, float]
) -> dict[int, float | None]:
    """Each node's Q for colouring: its own prediction's, else its nearest predicted
    ancestor's (:data:`Q_INHERITED`), else None. ``parents`` maps every node to its parent."""
    out: dict[int, float | None] = {}
    for start in parents:
        chain: list[int] = []
        current: int | None = start
        value: float | None = None
        while current is not None:
            if current in out:
                value = out[current]
                break
            if current in own:
                value = out[current] = own[current]
                break
            chain.append(current)
            if not Q_INHERITED:
                break
            current = parents.get(current)
        for node in chain:
            out[node] = value
    return out


# --- intervals ---------------------------------------------------------------------------------

MIN_INTERVAL_SEEDS = 10  # a bootstrap interval over fewer seeds than this says it is rough


def interval_note(seeds: int) -> str | None:
    """What an interval over ``seeds`` paired seeds must say beside it (None: nothing)."""
    if seeds >= MIN_INTERVAL_SEEDS:
        return None
    return (
        f"only {seeds} seed{'s' if seeds != 1 else ''}: a bootstrap interval over fewer than "
        f"{MIN_INTERVAL_SEEDS} is rough, and may not contain the mean"
    )


# --- for the page ------------------------------------------------------------------------------


def constant_names(names: Iterable[str]) -> dict[str, str]:
    """``{"NODE_ADDED": "node_added", ...}``: how the page names each name (``EVENT.NODE_ADDED``,
    ``STATUS.RUNNING``), so a name it uses that Python does not define is undefined there."""
    return {name.upper(): name for name in names}


def definitions() -> dict[str, Any]:
    """Everything above as JSON data, for the page, with the names of the event types
    (:mod:`planner.events`) and of every status (:mod:`planner.status`)."""
    return {
        "event": constant_names(EVENT_TYPES),
        "status": constant_names(all_status_names()),
        "run_statuses": list(RUN_STATUSES),
        "live_statuses": list(LIVE_STATUSES),
        "bench_statuses": list(BENCH_STATUSES),
        "train_statuses": list(TRAIN_STATUSES),
        "status_text": STATUS_TEXT,
        "query_kinds": list(QUERY_KINDS),
        "query_kind_text": QUERY_KIND_TEXT,
        "query_kind_rgb": {k: list(v) for k, v in QUERY_KIND_RGB.items()},
        "q_percentiles": list(Q_PERCENTILES),
        "q_stops": [list(s) for s in Q_STOPS],
        "no_prediction_rgb": list(NO_PREDICTION_RGB),
        "q_inherited": Q_INHERITED,
        "min_interval_seeds": MIN_INTERVAL_SEEDS,
    }


def definitions_js() -> str:
    """An ES module of :func:`definitions`: one ``export const`` per name (upper case)."""
    data = definitions()
    lines = [
        "// Generated from planner/figures.py (GET /generated/definitions.js): do not edit.",
        f"export const DEFINITIONS = {json.dumps(data, sort_keys=True)};",
    ]
    lines += [f"export const {k.upper()} = DEFINITIONS.{k};" for k in sorted(data)]
    return "\n".join(lines) + "\n"
