"""Benchmark analysis: the learned planner's lead as the horizon grows (blocks per scene).

    .venv/bin/python benchmarks/horizon.py BENCH_ID@bench-k2.db BENCH_ID@bench-k4.db \\
        BENCH_ID@bench-k6.db BENCH_ID@bench-k8.db --out horizon.html

Each argument is one benchmark (``tamp bench``) as ``ID@DB``; benchmarks of the same scene are
pooled (their seeds must not overlap). Per scene it prints the paired improvement of the second
planner over the first (``1 - mean(ours) / mean(reference)``, bootstrap 95% interval, as in
``tamp report``) of total time (a timeout counted at its budget), of planning, and of execution
(over seeds both solved), and the *zero-planning bound*: the improvement a planner would reach
that executed the second planner's plans and planned in no time at all,
``1 - mean(ours execution) / mean(reference total)`` over seeds both solved. Where that bound is
below a target, no search, however well guided, reaches the target on that scene.
``--out`` writes a plotly figure of the same.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np

from planner.report import paired_improvement, summarize


def blocks(scene: str) -> int:
    """Blocks of a ``kitchen-N`` scene (the horizon: each block is picked and moved 3 times)."""
    m = re.fullmatch(r"[a-z]+-(\d+)", scene)
    if m is None:
        raise ValueError(f"scene {scene!r} is not of the form NAME-N")
    return int(m.group(1))


def pool(specs: list[str]) -> dict[str, dict[str, Any]]:
    """Per scene: planners, budgets, bench ids and the pooled per-seed rows of ``summarize``."""
    scenes: dict[str, dict[str, Any]] = {}
    for spec in specs:
        bench_id, sep, db = spec.partition("@")
        if not sep or not db:
            raise ValueError(f"{spec!r}: expected BENCH_ID@DB")
        if not Path(db).exists():
            raise ValueError(f"{spec!r}: no such store {db}")
        try:
            s = summarize(db, bench_id)
        except KeyError as err:
            raise ValueError(f"{spec}: {err.args[0]}") from None
        scene, planners = s["config"]["scene"], list(s["config"]["planners"])
        entry = scenes.setdefault(
            scene, {"planners": planners, "benches": [], "budgets": set(), "rows": {}}
        )
        if entry["planners"] != planners:
            raise ValueError(f"{spec}: planners {planners} differ from {entry['planners']}")
        entry["benches"].append({"id": bench_id, "db": db, "code": s["config"].get("code")})
        entry["budgets"].add(float(s["config"]["budget_s"]))
        for row in s["trials"]:
            if row["seed"] in entry["rows"]:
                raise ValueError(f"{spec}: seed {row['seed']} of {scene} is in two benchmarks")
            if all(row[p]["status"] is not None for p in planners):  # skip unfinished seeds
                entry["rows"][row["seed"]] = row
    for scene, entry in scenes.items():
        if not entry["rows"]:
            raise ValueError(f"{scene}: no seed that every planner has finished")
    return scenes


def analyse(entry: dict[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    reference, ours = entry["planners"][0], entry["planners"][1]
    rows = list(entry["rows"].values())
    both = [r for r in rows if r[reference]["status"] == r[ours]["status"] == "solved"]

    def improvement(measure: str, pool: list[dict[str, Any]]) -> dict[str, Any]:
        return paired_improvement(
            [r[ours][measure] for r in pool], [r[reference][measure] for r in pool], rng
        )

    bound = paired_improvement(
        [r[ours]["execution"] for r in both], [r[reference]["total"] for r in both], rng
    )
    return {
        "reference": reference,
        "planner": ours,
        "seeds": len(rows),
        "solved": {p: sum(r[p]["status"] == "solved" for r in rows) for p in (reference, ours)},
        "mean_total_s": {
            p: float(np.mean([r[p]["total"] for r in rows])) if rows else None
            for p in (reference, ours)
        },
        "total": improvement("total", rows),
        "planning": improvement("planning", rows),
        "execution": improvement("execution", both),
        "zero_planning_bound": bound,
    }


def _pct(i: dict[str, Any]) -> str:
    if i["mean"] is None:
        return "-"
    return f"{100 * i['mean']:.1f}% ({100 * i['low']:.1f} to {100 * i['high']:.1f})"


def figure(results: dict[str, dict[str, Any]], target: float | None, out: Path) -> None:
    import plotly.graph_objects as go

    scenes = sorted(results, key=blocks)
    xs = [blocks(s) for s in scenes]
    fig = go.Figure()
    for key, name, dash in (
        ("total", "total time (timeouts at the budget)", "solid"),
        ("planning", "planning time", "dot"),
        ("zero_planning_bound", "zero-planning bound", "dash"),
    ):
        ys = [100 * results[s][key]["mean"] for s in scenes]
        fig.add_trace(
            go.Scatter(
                x=xs,
                y=ys,
                name=name,
                mode="lines+markers",
                line={"dash": dash},
                error_y={
                    "type": "data",
                    "symmetric": False,
                    "array": [
                        100 * results[s][key]["high"] - y for s, y in zip(scenes, ys, strict=True)
                    ],
                    "arrayminus": [
                        y - 100 * results[s][key]["low"] for s, y in zip(scenes, ys, strict=True)
                    ],
                },
                text=[f"{s}: {results[s]['seeds']} seeds" for s in scenes],
            )
        )
    if target is not None:
        fig.add_hline(y=100 * target, line_dash="dashdot", annotation_text="target")
    first = results[scenes[0]]
    fig.update_layout(
        title=f"{first['planner']} vs {first['reference']}: paired mean improvement "
        "(95% bootstrap interval) by number of blocks",
        xaxis_title="blocks (each cleaned, then cooked)",
        yaxis_title="% less than the baseline",
        xaxis={"tickvals": xs},
    )
    out.write_text(fig.to_html(include_plotlyjs=True, full_html=True))


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("benches", nargs="+", metavar="BENCH_ID@DB")
    parser.add_argument("--out", type=Path, help="write a plotly figure (HTML) here")
    parser.add_argument("--target", type=float, default=0.45, help="drawn as a line (0.45)")
    args = parser.parse_args()
    try:
        scenes = pool(args.benches)
        order = sorted(scenes, key=blocks)
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    # A fresh generator per scene: a scene's intervals do not depend on the other arguments.
    results = {s: analyse(scenes[s], np.random.default_rng(0)) for s in order}
    print(
        "| scene | seeds | solved (reference / ours) | mean total s (reference / ours) "
        "| total | planning | execution (both solved) | zero-planning bound | benchmarks (code) |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for s in order:
        r, entry = results[s], scenes[s]
        solved = " / ".join(str(r["solved"][p]) for p in (r["reference"], r["planner"]))
        means = " / ".join(f"{r['mean_total_s'][p]:.1f}" for p in (r["reference"], r["planner"]))
        benches = ", ".join(f"{b['id']} (code {b['code'] or '?'})" for b in entry["benches"])
        budgets = "/".join(f"{b:g}" for b in sorted(entry["budgets"]))
        print(
            f"| {s} (budget {budgets} s) | {r['seeds']} | {solved} | {means} "
            f"| **{_pct(r['total'])}** | {_pct(r['planning'])} | {_pct(r['execution'])} "
            f"| {_pct(r['zero_planning_bound'])} | {benches} |"
        )
    if args.out:
        figure(results, args.target, args.out)
        print(f"figure: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
