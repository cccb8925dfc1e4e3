"""The report of a benchmark: the paper's Fig. 2 comparison, with honest statistics.

Per trial, total time is planning + execution seconds. A trial that did not solve within its
budget counts as the budget with no execution ("censored at the budget"): conservative for the
planner that solves more. The paired improvement of a planner over the reference (the first
planner of the benchmark, normally the baseline) is ``1 - mean(total) / mean(reference total)``
over the same seeds, with a 95% interval from resampling seeds (bootstrap).
"""

from __future__ import annotations

import html
import json
import math
import re
import statistics
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from planner import figures
from planner.store import BenchTrialRecord, QueryOutcome, RunStore

BOOTSTRAP = 5000  # resamples for the intervals
MEASURES = ("planning", "execution", "total")


def _count_bounds(config: dict[str, Any]) -> str:
    """The trials' bounds besides their seconds, as the report's header says them ("" when
    none: every benchmark before them)."""
    parts = [
        f"{config[key]} {what}"
        for key, what in (("max_queries", "queries"), ("max_iterations", "iterations"))
        if config.get(key) is not None
    ]
    return f" or {' or '.join(parts)}" if parts else ""


def _times(t: BenchTrialRecord, budget: float) -> dict[str, float]:
    if t.status == "solved" and t.planning_s is not None:
        execution = t.execution_s or 0.0
        return {"planning": t.planning_s, "execution": execution, "total": t.planning_s + execution}
    return {"planning": budget, "execution": 0.0, "total": budget}


def _stats(values: Sequence[float]) -> dict[str, float | None]:
    if not values:
        return {"mean": None, "median": None}
    return {"mean": statistics.fmean(values), "median": statistics.median(values)}


def paired_improvement(
    ours: Sequence[float],
    reference: Sequence[float],
    rng: np.random.Generator,
    resamples: npt.NDArray[np.intp] | None = None,
) -> dict[str, float | int | str | None]:
    """``1 - mean(ours) / mean(reference)`` over paired seeds, with a bootstrap 95% interval.
    ``resamples`` (:data:`BOOTSTRAP` rows of seed indices) lets measures of the same seeds share
    one draw; without, ``rng`` draws them. ``note`` says when there are too few seeds for the
    interval to mean much (:func:`planner.figures.interval_note`), else None."""
    n = len(ours)
    note = figures.interval_note(n)  # under 10 seeds, the interval says it is rough
    if n == 0 or sum(reference) <= 0:
        return {"n": n, "mean": None, "low": None, "high": None, "note": note}
    a, b = np.asarray(ours), np.asarray(reference)
    point = 1.0 - a.mean() / b.mean()
    idx = rng.integers(0, n, size=(BOOTSTRAP, n)) if resamples is None else resamples
    if idx.shape != (BOOTSTRAP, n):
        raise ValueError(f"resamples of shape {idx.shape} for {n} seeds")
    samples = 1.0 - a[idx].mean(axis=1) / np.maximum(b[idx].mean(axis=1), 1e-12)
    low, high = np.percentile(samples, [2.5, 97.5])
    return {"n": n, "mean": float(point), "low": float(low), "high": float(high), "note": note}


def failure_kind(q: QueryOutcome) -> str:
    """A failed query's reason without its numbers, so that failures of one kind count
    together: "base: no path in N iterations"; a breakdown's counts go ("no arm configuration
    from N base poses (grasp in collision, out of the arm's reach)")."""
    if q.error is not None:
        return f"error: {q.error.split(':', 1)[0]}"
    if not q.reason:
        return "no reason given"
    kind = re.sub(r" \d+(?=[,)])", "", q.reason)  # "cause 12," -> "cause,"
    return re.sub(r"\d+(\.\d+)?", "N", kind)


def query_summary(outcomes: Iterable[QueryOutcome]) -> dict[str, Any]:
    """Per stream: queries, failures and their seconds, and the failures by kind (most first)."""
    streams: dict[str, dict[str, Any]] = {}
    for q in outcomes:
        entry = streams.setdefault(
            q.stream, {"queries": 0, "failed": 0, "failed_s": 0.0, "kinds": {}}
        )
        entry["queries"] += 1
        if q.success:
            continue
        entry["failed"] += 1
        entry["failed_s"] += q.wall_s
        kind = entry["kinds"].setdefault(failure_kind(q), {"count": 0, "seconds": 0.0})
        kind["count"] += 1
        kind["seconds"] += q.wall_s
    for entry in streams.values():
        entry["kinds"] = [
            {"kind": k, **v}
            for k, v in sorted(entry["kinds"].items(), key=lambda kv: (-kv[1]["count"], kv[0]))
        ]
    return dict(sorted(streams.items()))


def run_time_split(
    planning_s: float,
    until_plans_s: float,
    outcomes: Iterable[QueryOutcome],
    search_cpu_s: float | None = None,
    later_skeletons_s: float = 0.0,
) -> dict[str, Any]:
    """Where one run's planning seconds went: until the first skeletons were found (the
    skeleton source, and a learned planner's model loading and stream order), the skeletons the
    search asked for later (``later_skeletons_s``), the stream queries' own seconds (in all and
    per stream), and the rest, the search itself (selection, a learned planner's feature rows
    and predictions, events). ``outcomes`` are the run's queries.

    ``search_s`` is wall time, so on a busy machine it holds the seconds the search waited for
    a core; ``search_cpu_s`` (recorded by the run, None for runs before it was) is the
    search thread's own CPU seconds outside the queries, which other processes do not add to."""
    by_stream: dict[str, float] = {}
    for q in outcomes:
        by_stream[q.stream] = by_stream.get(q.stream, 0.0) + q.wall_s
    queries = sum(by_stream.values())
    return {
        "planning_s": planning_s,
        "until_plans_s": until_plans_s,
        "later_skeletons_s": later_skeletons_s,
        "queries_s": queries,
        "queries_by_stream_s": dict(sorted(by_stream.items())),
        "search_s": planning_s - until_plans_s - later_skeletons_s - queries,
        "search_cpu_s": search_cpu_s,
    }


def time_split(
    trials: Sequence[BenchTrialRecord],
    plans_at: Mapping[str, float],
    outcomes: Iterable[QueryOutcome],
    search_cpu: Mapping[str, float] | None = None,
    later: Mapping[str, float] | None = None,
) -> dict[str, Any]:
    """:func:`run_time_split` of a planner's trials, on average over the trials with a run
    (``search_cpu_s``: over those that recorded it, None if none did)."""
    ids = {t.run_id for t in trials if t.run_id and t.planning_s is not None}
    if not ids:
        return {
            "planning_s": None,
            "until_plans_s": None,
            "later_skeletons_s": None,
            "queries_s": None,
            "queries_by_stream_s": {},
            "search_s": None,
            "search_cpu_s": None,
        }
    mine: dict[str, list[QueryOutcome]] = {run_id: [] for run_id in ids}
    for q in outcomes:
        if q.run_id in mine:
            mine[q.run_id].append(q)
    cpu = search_cpu or {}
    splits = [
        run_time_split(
            t.planning_s or 0.0,
            plans_at.get(t.run_id or "", 0.0),
            mine[t.run_id or ""],
            cpu.get(t.run_id or ""),
            (later or {}).get(t.run_id or "", 0.0),
        )
        for t in trials
        if t.run_id in ids
    ]
    cpus = [s["search_cpu_s"] for s in splits if s["search_cpu_s"] is not None]
    n = len(splits)
    streams = sorted({s for split in splits for s in split["queries_by_stream_s"]})

    def mean(key: str) -> float:
        return float(sum(split[key] for split in splits)) / n

    return {
        "planning_s": mean("planning_s"),
        "until_plans_s": mean("until_plans_s"),
        "later_skeletons_s": mean("later_skeletons_s"),
        "queries_s": mean("queries_s"),
        "queries_by_stream_s": {
            stream: sum(split["queries_by_stream_s"].get(stream, 0.0) for split in splits) / n
            for stream in streams
        },
        "search_s": mean("search_s"),
        "search_cpu_s": sum(cpus) / len(cpus) if cpus else None,
    }


LEARNED = "learned"  # the planner a benchmark's variants are compared with as well


def _pair(
    by: Mapping[str, Mapping[int, BenchTrialRecord]],
    planner: str,
    reference: str,
    budget: float,
    rng: np.random.Generator,
) -> dict[str, Any]:
    """``planner`` against ``reference`` over their paired seeds: each measure's paired
    improvement, unsolved trials counted at the budget (censored) and over the seeds both
    solved."""
    seeds = sorted(set(by[planner]) & set(by[reference]))
    both = [
        s
        for s in seeds
        if by[planner][s].status == "solved" and by[reference][s].status == "solved"
    ]
    entry: dict[str, Any] = {"seeds": len(seeds), "both_solved": len(both)}
    # One draw of resampled seeds per pool, shared by the measures (a benchmark page of 1,000
    # seeds spent more than half its summary drawing one per interval). ``both`` is a subset
    # of ``seeds``: of the same length, it is the same pool.
    draw_all = rng.integers(0, len(seeds), size=(BOOTSTRAP, len(seeds)))
    draw_both = (
        draw_all
        if len(both) == len(seeds)
        else rng.integers(0, len(both), size=(BOOTSTRAP, len(both)))
    )
    for m in MEASURES:
        # An unsolved trial has no execution to compare: execution is over both-solved seeds.
        censored = (both, draw_both) if m == "execution" else (seeds, draw_all)
        for name, (pool, draw) in (
            (f"{m}_censored", censored),
            (f"{m}_both_solved", (both, draw_both)),
        ):
            entry[name] = paired_improvement(
                [_times(by[planner][s], budget)[m] for s in pool],
                [_times(by[reference][s], budget)[m] for s in pool],
                rng,
                draw,
            )
    return entry


def summarize(db: str | Path, bench_id: str) -> dict[str, Any]:
    """Everything the report shows, as JSON data (``tamp report --json``)."""
    with RunStore(db) as store:
        bench = store.get_bench(bench_id)
        trials = store.bench_trials(bench_id)
        run_ids = [t.run_id for t in trials if t.run_id]
        outcomes = store.query_outcomes(run_ids)
        plans_at = store.event_times(run_ids, "abstract_plans_found")
        search_cpu = store.event_numbers(run_ids, "run_finished", "search_cpu_s")
        skeleton_s = store.event_numbers(run_ids, "run_finished", "skeleton_s")
        first_s = store.event_numbers(run_ids, "abstract_plans_found", "seconds")
    # The skeleton source's seconds per run (every batch), and those of the batches the search
    # asked for after the first (runs recorded before they were counted: the first's only).
    skeletons = {r: skeleton_s.get(r, first_s.get(r, 0.0)) for r in run_ids}
    later = {r: max(skeletons[r] - first_s.get(r, skeletons[r]), 0.0) for r in run_ids}
    planner_of = {t.run_id: t.planner for t in trials if t.run_id}
    config = bench.config
    planners: list[str] = list(config["planners"])
    budget = float(config["budget_s"])
    by: dict[str, dict[int, BenchTrialRecord]] = {p: {} for p in planners}
    for t in trials:
        by.setdefault(t.planner, {})[t.seed] = t
    per_planner: dict[str, Any] = {}
    for p in planners:
        ts = list(by[p].values())
        solved = [t for t in ts if t.status == "solved"]
        times = [_times(t, budget) for t in solved]
        ratios = [
            t.planning_s / t.oracle_s for t in solved if t.planning_s is not None and t.oracle_s
        ]
        per_planner[p] = {
            "trials": len(ts),
            "solved": len(solved),
            "solved_fraction": len(solved) / len(ts) if ts else None,
            "failed": sum(1 for t in ts if t.status in ("failed", "crashed")),
            "invalid_plans": sum(1 for t in ts if t.valid is False),
            **{f"{m}_s": _stats([x[m] for x in times]) for m in MEASURES},  # over solved trials
            "total_s_censored": _stats([_times(t, budget)["total"] for t in ts]),
            "planning_over_oracle": _stats(ratios),
            "time_split": time_split(
                [t for t in ts if t.run_id], plans_at, outcomes, search_cpu, later
            ),  # over every trial with a run
            "skeleton_s": _stats([skeletons[t.run_id] for t in ts if t.run_id]),
            "queries": query_summary(q for q in outcomes if planner_of.get(q.run_id) == p),
        }
    rng = np.random.default_rng(0)
    reference = planners[0]
    paired = {p: _pair(by, p, reference, budget, rng) for p in planners[1:]}
    # A benchmark of variants (tamp bench --planners baseline,paper,learned,learned:x=off):
    # every planner against learned too, the configuration the variants are ablations of. With
    # only the reference beside learned, that is the paired figure the other way round.
    against: dict[str, dict[str, Any]] = {}
    for ref in (LEARNED,):
        if ref in planners and ref != reference and len(planners) > 2:
            against[ref] = {p: _pair(by, p, ref, budget, rng) for p in planners if p != ref}
    rows = [
        {
            "seed": s,
            **{
                p: {
                    "status": by[p][s].status if s in by[p] else None,
                    **(_times(by[p][s], budget) if s in by[p] else {}),
                    "run_id": by[p][s].run_id if s in by[p] else None,
                    "error": by[p][s].error if s in by[p] else None,
                    # the skeleton source's seconds (every batch): planning's part not searched
                    "skeleton": skeletons.get(by[p][s].run_id or "") if s in by[p] else None,
                }
                for p in planners
            },
        }
        for s in sorted({t.seed for t in trials})
    ]
    return {
        "bench_id": bench_id,
        "status": bench.status,
        "created_at": bench.created_at.isoformat(timespec="seconds"),
        "finished_at": bench.finished_at.isoformat(timespec="seconds")
        if bench.finished_at
        else None,
        "wall_s": (bench.finished_at - bench.created_at).total_seconds()
        if bench.finished_at
        else None,
        "config": config,
        "reference": reference,
        "planners": per_planner,
        "paired": paired,
        "paired_against": against,
        "trials": rows,
    }


def _change(v: float | None) -> str:
    """An improvement as words: "41.9% less" or "12.0% more"."""
    if v is None or math.isnan(v):
        return "-"
    return f"{100 * abs(v):.1f}% {'less' if v >= 0 else 'more'}"


def _fmt(v: Any, pct: bool = False) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "-"
    if pct:
        return f"{100 * v:.1f}%"
    return f"{v:.1f}" if isinstance(v, float) else str(v)


def _fmt2(v: float | None) -> str:
    """Seconds to two decimals (the search's own seconds are fractions of one)."""
    return "-" if v is None or math.isnan(v) else f"{v:.2f}"


def table_markdown(summary: dict[str, Any]) -> str:
    """The per-planner table and the paired improvements, as markdown."""
    lines = [
        "| planner | solved | mean / median planning s | mean / median execution s | "
        "mean / median total s | planning / oracle (median) |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for p, s in summary["planners"].items():
        lines.append(
            f"| {p} | {s['solved']}/{s['trials']} | {_fmt(s['planning_s']['mean'])} / "
            f"{_fmt(s['planning_s']['median'])} | {_fmt(s['execution_s']['mean'])} / "
            f"{_fmt(s['execution_s']['median'])} | {_fmt(s['total_s']['mean'])} / "
            f"{_fmt(s['total_s']['median'])} | {_fmt(s['planning_over_oracle']['median'])} |"
        )
    for p, e in summary["paired"].items():
        c, b = e["total_censored"], e["total_both_solved"]
        lines.append("")
        lines.append(
            f"{p} vs {summary['reference']}: {_change(c['mean'])} mean total time (improvement "
            f"{_fmt(c['mean'], True)}, 95% CI {_fmt(c['low'], True)} to {_fmt(c['high'], True)}) "
            f"over {c['n']} paired seeds, unsolved trials counted at the budget; improvement "
            f"{_fmt(b['mean'], True)} ({_fmt(b['low'], True)} to {_fmt(b['high'], True)}) over "
            f"the {b['n']} seeds both solved." + (f" Note: {c['note']}." if c.get("note") else "")
        )
    for ref, entries in summary.get("paired_against", {}).items():
        lines += ["", *_ablation_markdown(summary, ref, entries)]
    lines += ["", *_query_markdown(summary)]
    return "\n".join(lines)


def _ci(e: Mapping[str, Any]) -> str:
    """A paired change and its interval in the same words: "5.7% more (9.3% more to 2.0% more)"."""
    if e["mean"] is None or math.isnan(e["mean"]):
        return "-"  # no seed both solved (execution)
    return f"{_change(e['mean'])} ({_change(e['low'])} to {_change(e['high'])})"


def _ablation_markdown(
    summary: Mapping[str, Any], ref: str, entries: Mapping[str, Any]
) -> list[str]:
    """Every planner against ``ref`` (and the benchmark's reference): total, planning and
    execution, paired, 95% intervals (the improvement is ours over theirs: "less" is better)."""
    base = summary["reference"]
    lines = [
        f"| planner | solved | total vs {ref} | planning vs {ref} | execution vs {ref} | "
        f"total vs {base} | search s, wall / CPU |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for p, s in summary["planners"].items():
        mine = entries.get(p)
        vs_base = summary["paired"].get(p)
        split = s.get("time_split", {})
        lines.append(
            f"| {p} | {s['solved']}/{s['trials']} | "
            + (
                f"{_ci(mine['total_censored'])} | {_ci(mine['planning_censored'])} | "
                f"{_ci(mine['execution_censored'])}"
                if mine is not None
                else "- | - | -"
            )
            + f" | {_ci(vs_base['total_censored']) if vs_base is not None else '-'} | "
            + f"{_fmt2(split.get('search_s'))} / {_fmt2(split.get('search_cpu_s'))} |"
        )
    return lines


def _kinds_text(entry: dict[str, Any], limit: int = 4) -> str:
    kinds = entry["kinds"]
    text = ", ".join(f"{k['kind']} {k['count']}" for k in kinds[:limit])
    if len(kinds) > limit:
        text += f", {len(kinds) - limit} other kinds"
    return text


def _query_markdown(summary: dict[str, Any]) -> list[str]:
    """Stream queries per planner and stream: how many failed, their seconds, and why."""
    lines = [
        "| planner | stream | queries | failed | s in failures | failures by kind |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for p, s in summary["planners"].items():
        for stream, e in s.get("queries", {}).items():
            lines.append(
                f"| {p} | {stream} | {e['queries']} | {e['failed']} | {e['failed_s']:.1f} | "
                f"{_kinds_text(e) or '-'} |"
            )
    return lines


def render_html(summary: dict[str, Any]) -> str:
    """A self-contained HTML page (plotly's JS inlined once) with the figures and tables."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    planners = list(summary["planners"])
    reference = summary["reference"]
    budget = float(summary["config"]["budget_s"])
    figures: list[Any] = []
    colours = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd"]
    for other in planners[1:]:
        fig = make_subplots(rows=1, cols=3, subplot_titles=[f"{m} (s)" for m in MEASURES])
        for col, m in enumerate(MEASURES, 1):
            xs, ys, text, symbols = [], [], [], []
            for row in summary["trials"]:
                a, b = row.get(reference, {}), row.get(other, {})
                if m not in a or m not in b:
                    continue
                if m == "execution" and not a["status"] == b["status"] == "solved":
                    continue  # nothing was executed
                xs.append(a[m])
                ys.append(b[m])
                text.append(f"seed {row['seed']}: {a['status']} / {b['status']}")
                symbols.append("circle" if a["status"] == b["status"] == "solved" else "x")
            top = max([*xs, *ys, 1.0])
            fig.add_trace(
                go.Scatter(
                    x=xs,
                    y=ys,
                    mode="markers",
                    text=text,
                    marker={"symbol": symbols},
                    name=m,
                    showlegend=False,
                ),
                row=1,
                col=col,
            )
            fig.add_trace(
                go.Scatter(
                    x=[0, top],
                    y=[0, top],
                    mode="lines",
                    line={"dash": "dot", "color": "grey"},
                    showlegend=False,
                    hoverinfo="skip",
                ),
                row=1,
                col=col,
            )
            fig.update_xaxes(title_text=f"{reference} (s)", row=1, col=col)
            fig.update_yaxes(title_text=f"{other} (s)", row=1, col=col)
        fig.update_layout(
            title=f"Per trial: {reference} (x) vs {other} (y); below the diagonal, {other} is "
            "faster; x: one of them did not solve (counted at the budget; no execution shown)",
            height=420,
        )
        figures.append(fig)
    dist = go.Figure()
    for i, p in enumerate(planners):
        totals = [row[p]["total"] for row in summary["trials"] if row.get(p, {}).get("total")]
        dist.add_trace(
            go.Box(
                y=totals,
                name=p,
                boxpoints="all",
                jitter=0.4,
                marker_color=colours[i % len(colours)],
            )
        )
    dist.update_layout(title="Total time per trial (s; unsolved at the budget)", height=420)
    figures.append(dist)
    cdf = go.Figure()
    for i, p in enumerate(planners):
        done = sorted(
            row[p]["planning"]
            for row in summary["trials"]
            if row.get(p, {}).get("status") == "solved"
        )
        n = max(summary["planners"][p]["trials"], 1)
        cdf.add_trace(
            go.Scatter(
                x=[0, *done, budget],
                y=[0, *[(k + 1) / n for k in range(len(done))], len(done) / n],
                mode="lines",
                line={"shape": "hv"},
                name=p,
                marker_color=colours[i % len(colours)],
            )
        )
    cdf.update_layout(
        title="Solved within t seconds of planning (fraction of trials)",
        xaxis_title="planning seconds",
        yaxis_title="solved fraction",
        yaxis_range=[0, 1.02],
        height=380,
    )
    figures.append(cdf)
    parts = []
    for i, fig in enumerate(figures):
        parts.append(fig.to_html(full_html=False, include_plotlyjs="inline" if i == 0 else False))
    config = summary["config"]
    trained = config.get("training_seeds")
    trained_text = (
        "; ".join(
            f"{scene}: seeds {min(s)}-{max(s)} ({len(s)} runs)" for scene, s in trained.items()
        )
        if trained
        else "not recorded in the model file"
        if config.get("model")
        else "no learned planner"
    )
    table = _html_table(summary)
    seeds = config["seeds"]
    head = (
        f"<h1>Benchmark {html.escape(summary['bench_id'])}</h1>"
        f"<p>{html.escape(config['scene'])}, planners {html.escape(', '.join(planners))}, "
        f"{len(seeds)} seeds ({min(seeds)}-{max(seeds)}), budget {budget:.0f} s per trial"
        f"{_count_bounds(config)}, stream order {html.escape(str(config.get('order', 'auto')))}; "
        f"status {html.escape(summary['status'])}; started {summary['created_at']}"
        + (f", wall time {summary['wall_s'] / 60:.1f} min" if summary["wall_s"] else "")
        + "</p>"
        f"<p>Code: {html.escape(str(config.get('code', 'not recorded')))}. "
        f"Model: {html.escape(str(config.get('model')))}; it was trained on "
        f"{html.escape(trained_text)}. The benchmark's seeds were held out.</p>"
    )
    return (
        "<!doctype html><html><head><meta charset='utf-8'><title>guided-tamp benchmark "
        f"{html.escape(summary['bench_id'])}</title><style>body{{font-family:system-ui,sans-serif;"
        "margin:2em;max-width:1300px}table{border-collapse:collapse}td,th{border:1px solid #ccc;"
        "padding:4px 8px;text-align:right}th{background:#f3f3f3}</style></head><body>"
        + head
        + table
        + "".join(parts)
        + _query_html(summary)
        + _seed_table(summary)
        + "<details><summary>Data (JSON)</summary><pre>"
        + html.escape(json.dumps(summary, indent=1))
        + "</pre></details></body></html>"
    )


def _seed_table(summary: dict[str, Any]) -> str:
    """Every trial: status and seconds per planner, each linked to its run on the dashboard
    (served from the same database: ``tamp serve --db``). Seeds some planner did not solve are
    listed first."""
    planners = list(summary["planners"])

    def cell(t: dict[str, Any]) -> str:
        if not t or t.get("status") is None:
            return "<td>-</td>"
        status = html.escape(str(t["status"]))
        text = (
            f"{t['planning']:.1f} + {t['execution']:.1f}"
            if t["status"] == "solved"
            else f"<b style='color:#c62828'>{status}</b>"
        )
        if t.get("error"):
            text += f" <small>{html.escape(str(t['error'])[:120])}</small>"
        if t.get("run_id"):
            rid = html.escape(str(t["run_id"]))
            text = f"<a href='/#run={rid}' title='run {rid}'>{text}</a>"
        return f"<td>{text}</td>"

    rows = sorted(
        summary["trials"],
        key=lambda r: (all(r.get(p, {}).get("status") == "solved" for p in planners), r["seed"]),
    )
    head = "".join(f"<th>{html.escape(p)}: planning + execution s</th>" for p in planners)
    body = "".join(
        f"<tr><td>{r['seed']}</td>{''.join(cell(r.get(p, {})) for p in planners)}</tr>"
        for r in rows
    )
    unsolved = sum(
        1 for r in rows if not all(r.get(p, {}).get("status") == "solved" for p in planners)
    )
    return (
        f"<details><summary>Per seed ({len(rows)} seeds; the {unsolved} some planner did not "
        "solve first; links open the run on the dashboard serving this database)</summary>"
        f"<table><tr><th>seed</th>{head}</tr>{body}</table></details>"
    )


def _query_html(summary: dict[str, Any]) -> str:
    """Stream queries per planner and stream, and the failures by kind (what the samplers said:
    no path in the iteration limit, a start in collision, no IK ...)."""
    body = []
    for p, s in summary["planners"].items():
        for stream, e in s.get("queries", {}).items():
            kinds = "<br>".join(
                f"{html.escape(k['kind'])}: {k['count']} ({k['seconds']:.1f} s)" for k in e["kinds"]
            )
            body.append(
                f"<tr><td>{html.escape(p)}</td><td>{html.escape(stream)}</td>"
                f"<td>{e['queries']}</td><td>{e['failed']}</td><td>{e['failed_s']:.1f}</td>"
                f"<td style='text-align:left'>{kinds or '-'}</td></tr>"
            )
    return (
        "<h2>Stream queries and why they failed</h2><table data-testid='query-table'><tr>"
        "<th>planner</th><th>stream</th><th>queries</th><th>failed</th><th>s in failures</th>"
        "<th>failures by kind (count, seconds)</th></tr>" + "".join(body) + "</table>"
    )


def _html_table(summary: dict[str, Any]) -> str:
    rows = [
        "<table><tr><th>planner</th><th>solved</th><th>planning s mean / median</th>"
        "<th>execution s mean / median</th><th>total s mean / median</th>"
        "<th>planning / oracle (median)</th><th>crashed</th></tr>"
    ]
    for p, s in summary["planners"].items():
        rows.append(
            f"<tr><td>{html.escape(p)}</td><td>{s['solved']}/{s['trials']}</td>"
            f"<td>{_fmt(s['planning_s']['mean'])} / {_fmt(s['planning_s']['median'])}</td>"
            f"<td>{_fmt(s['execution_s']['mean'])} / {_fmt(s['execution_s']['median'])}</td>"
            f"<td>{_fmt(s['total_s']['mean'])} / {_fmt(s['total_s']['median'])}</td>"
            f"<td>{_fmt(s['planning_over_oracle']['median'])}</td><td>{s['failed']}</td></tr>"
        )
    rows.append("</table>")
    for p, e in summary["paired"].items():
        items = []
        for m in MEASURES:
            c = e[f"{m}_censored"]
            where = (
                "seeds both solved" if m == "execution" else "paired seeds, unsolved at the budget"
            )
            items.append(
                f"<li>{m}: {_change(c['mean'])} (improvement {_fmt(c['mean'], True)}, 95% CI "
                f"{_fmt(c['low'], True)} to {_fmt(c['high'], True)}), {c['n']} {where}; "
                f"{_change(e[f'{m}_both_solved']['mean'])} over the "
                f"{e[f'{m}_both_solved']['n']} seeds both solved"
                + (f" <b>({html.escape(c['note'])})</b>" if c.get("note") else "")
                + "</li>"
            )
        rows.append(
            f"<h3>{html.escape(p)} vs {html.escape(summary['reference'])} (paired mean "
            f"improvement)</h3><ul>{''.join(items)}</ul>"
        )
    return "".join(rows)
