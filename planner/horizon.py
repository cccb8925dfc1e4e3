"""The horizon curve: planning and total time against the number of objects, per planner, over a
series of scenes of one domain (``tamp horizon``).

One benchmark per scene (``tamp bench``: the planners on the same seeds, trials interleaved), so
every point of a scene compares planners paired. A scene's number of objects is the number of
facts its goal names (kitchen-8 cooks 8 blocks, panda-6 puts 6 in the tray). A benchmark already
in the store with the same settings is taken as it is, or resumed when it did not finish: the
command is rerun to go on after an interruption.

Each point is a planner's mean over the scene's seeds, with a 95% bootstrap interval of the mean;
a trial that did not solve counts at the budget (planning and total: censored), as in ``tamp
report``. The table adds, per planner but the first, its paired improvement in total time over
the first and its *zero-planning bound*, ``1 - mean(its execution) / mean(the first's total)``
over the seeds both solved: what it would save if it planned in no time. A target above that
bound is out of reach of any search on that scene. The figure is written as HTML (plotly) and
as SVG (for docs; drawn here, no plotting library needed).
"""

from __future__ import annotations

import hashlib
import html
import json
import logging
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from planner.bench import BenchConfig, make_config, run_bench
from planner.domains import problem_for_scene
from planner.report import BOOTSTRAP, paired_improvement, summarize
from planner.store import RunStore

log = logging.getLogger(__name__)

MEASURES = ("planning", "total")  # the two panels


@dataclass(frozen=True)
class Point:
    """One planner on one scene: means and 95% intervals over the scene's seeds."""

    scene: str
    objects: int
    planner: str
    seeds: int
    solved: int
    bench_id: str
    code: str | None
    planning: tuple[float, float, float]  # mean, low, high (seconds; timeouts at the budget)
    total: tuple[float, float, float]
    # 1 - mean(total) / mean(reference total) over the same seeds (None for the reference)
    improvement: tuple[float, float, float] | None
    # The zero-planning bound: 1 - mean(execution) / mean(reference total) over the seeds both
    # solved, what this planner would save if it planned in no time (None for the reference)
    bound: tuple[float, float, float] | None = None
    # The skeleton source's share of planning: its seconds (every batch), mean and interval over
    # the seeds whose runs recorded them (None: none did)
    skeleton: tuple[float, float, float] | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "scene": self.scene,
            "objects": self.objects,
            "planner": self.planner,
            "seeds": self.seeds,
            "solved": self.solved,
            "bench_id": self.bench_id,
            "code": self.code,
            "planning": list(self.planning),
            "total": list(self.total),
            "improvement": None if self.improvement is None else list(self.improvement),
            "zero_planning_bound": None if self.bound is None else list(self.bound),
            "skeleton": None if self.skeleton is None else list(self.skeleton),
        }


def goal_objects(scene: str, domain: str | None = None) -> int:
    """How many facts the scene's goal names: the horizon of its task."""
    return scene_goal(scene, domain)[1]


def scene_goal(scene: str, domain: str | None = None) -> tuple[str, int]:
    """The name of the scene's domain and how many facts its goal names (one loading of the
    problem for both: the dashboard groups benchmarks by the first)."""
    loaded, problem = problem_for_scene(scene, domain=domain)
    return loaded.name, len(problem.goal)


def _same(config: dict[str, Any], wanted: BenchConfig) -> bool:
    """A stored benchmark's settings are ``wanted``'s: the same model counts by its content,
    wherever its file was (a benchmark run from another checkout of the same code)."""
    try:
        have = BenchConfig.from_dict(config)
    except (KeyError, TypeError, ValueError):
        return False
    if have.model is not None and wanted.model is not None and have.model != wanted.model:
        recorded = config.get("model_sha256")
        path = Path(wanted.model)
        if recorded is None or not path.is_file():
            return False
        if hashlib.sha256(path.read_bytes()).hexdigest() != recorded:
            return False
        have = replace(have, model=wanted.model)
    return have == wanted


def find_bench(db: str | Path, config: BenchConfig) -> tuple[str, str] | None:
    """The newest benchmark in ``db`` with exactly ``config``'s settings: (id, status)."""
    if "://" not in str(db) and not Path(db).is_file():
        return None
    with RunStore(db) as store:
        for bench in store.list_benches():
            if _same(bench.config, config):
                return bench.id, bench.status
    return None


def run_horizon(
    db: str | Path,
    scenes: Sequence[str],
    planners: Sequence[str],
    *,
    trials: int,
    seed_start: int,
    budget_s: float,
    model: str | None = None,
    domain: str | None = None,
    max_queries: int | None = None,
    max_iterations: int | None = None,
    workers: int = 2,
    ray_address: str | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[str]:
    """Run (or take, or resume) one benchmark per scene; returns their ids in scene order."""
    if not scenes:
        raise ValueError("--scenes: expected at least one scene")
    configs = [
        make_config(
            s,
            planners,
            trials=trials,
            seed_start=seed_start,
            budget_s=budget_s,
            model=model,
            domain=domain,
            max_queries=max_queries,
            max_iterations=max_iterations,
        )
        for s in scenes
    ]
    ids = []
    for i, config in enumerate(configs):
        found = find_bench(db, config)
        if found is not None and found[1] == "done":
            log.info("%s: benchmark %s is done, taken as it is", config.scene, found[0])
            ids.append(found[0])
            continue
        if progress is not None:
            progress(f"scene {i + 1}/{len(configs)}: {config.scene}")
        if found is not None:
            bench_id, _ = run_bench(
                db, resume=found[0], workers=workers, ray_address=ray_address, progress=progress
            )
        else:
            bench_id, _ = run_bench(
                db, config, workers=workers, ray_address=ray_address, progress=progress
            )
        ids.append(bench_id)
    return ids


def _interval(values: Sequence[float], rng: np.random.Generator) -> tuple[float, float, float]:
    a = np.asarray(values, dtype=float)
    idx = rng.integers(0, len(a), size=(BOOTSTRAP, len(a)))
    low, high = np.percentile(a[idx].mean(axis=1), [2.5, 97.5])
    return (float(a.mean()), float(low), float(high))


def points(db: str | Path, bench_ids: Sequence[str]) -> list[Point]:
    """Every planner of every benchmark as a :class:`Point` (seeds every planner finished)."""
    out: list[Point] = []
    for bench_id in bench_ids:
        s = summarize(db, bench_id)
        config = s["config"]
        objects = goal_objects(config["scene"], config.get("domain"))
        found = summary_points(s, objects)
        if not found:
            log.warning("benchmark %s has no seed every planner finished: left out", bench_id)
        out += found
    return out


def summary_points(summary: dict[str, Any], objects: int) -> list[Point]:
    """The points of one benchmark from its :func:`planner.report.summarize` (the dashboard
    keeps those): one per planner over the seeds every planner finished; none without such a
    seed."""
    config = summary["config"]
    planners: list[str] = list(config["planners"])
    rows = [r for r in summary["trials"] if all(r[p]["status"] is not None for p in planners)]
    if not rows:
        return []
    reference = summary["reference"]
    rng = np.random.default_rng(0)  # per benchmark: its intervals do not depend on the rest
    out: list[Point] = []
    for p in planners:
        improvement = bound = None
        if p != reference:
            pair = summary["paired"][p]["total_censored"]
            if pair["mean"] is not None:
                improvement = (pair["mean"], pair["low"], pair["high"])
            both = [r for r in rows if r[p]["status"] == r[reference]["status"] == "solved"]
            zero = paired_improvement(
                [r[p]["execution"] for r in both], [r[reference]["total"] for r in both], rng
            )
            mean, low, high = zero["mean"], zero["low"], zero["high"]
            if mean is not None and low is not None and high is not None:
                bound = (float(mean), float(low), float(high))
        skeletons = [r[p]["skeleton"] for r in rows if r[p].get("skeleton") is not None]
        out.append(
            Point(
                scene=_scene_name(str(config["scene"])),
                objects=objects,
                planner=p,
                seeds=len(rows),
                solved=sum(r[p]["status"] == "solved" for r in rows),
                bench_id=str(summary["bench_id"]),
                code=config.get("code"),
                planning=_interval([r[p]["planning"] for r in rows], rng),
                total=_interval([r[p]["total"] for r in rows], rng),
                improvement=improvement,
                bound=bound,
                skeleton=_interval(skeletons, rng) if skeletons else None,
            )
        )
    return out


def _scene_name(scene: str) -> str:
    """A scene given by path is named by its file (``.../tabletop-2.json``: tabletop-2)."""
    return Path(scene).stem if scene.endswith(".json") else scene


def _planners(pts: Sequence[Point]) -> list[str]:
    seen: list[str] = []
    for p in pts:
        if p.planner not in seen:
            seen.append(p.planner)
    return seen


def table_markdown(pts: Sequence[Point]) -> str:
    """One row per scene and planner: objects, solved, mean planning and total with intervals,
    total against the reference, and the zero-planning bound: what the planner would save
    against the reference if it planned in no time (where a target lies above it, no search
    reaches the target on that scene)."""
    lines = [
        "| scene | objects | planner | solved | planning s (95% interval) | of which skeletons "
        "| total s (95% interval) | total against the first planner | zero-planning bound "
        "| benchmark (code) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for p in sorted(pts, key=lambda q: (q.objects, _planners(pts).index(q.planner))):
        against = "-" if p.improvement is None else _change(*p.improvement)
        bound = "-" if p.bound is None else _change(*p.bound).replace("**", "")
        skeleton = "-" if p.skeleton is None else f"{p.skeleton[0]:.1f}"
        lines.append(
            f"| {p.scene} | {p.objects} | {p.planner} | {p.solved}/{p.seeds} "
            f"| {_ci(p.planning)} | {skeleton} | {_ci(p.total)} | {against} | {bound} "
            f"| {p.bench_id} ({p.code or '?'}) |"
        )
    return "\n".join(lines)


def _ci(v: tuple[float, float, float]) -> str:
    return f"{v[0]:.1f} ({v[1]:.1f} to {v[2]:.1f})"


def _side(v: float) -> str:
    return f"{100 * v:.1f}% less" if v >= 0 else f"{-100 * v:.1f}% more"


def _change(mean: float, low: float, high: float) -> str:
    """An improvement and its interval in words: "**36.4% less** (27.9% to 43.6% less)",
    "17.4% more (1.4% less to 39.1% more)"."""
    head = f"**{_side(mean)}**" if low > 0 else _side(mean)
    if low >= 0 or high < 0:  # both ends on one side
        a, b = sorted((abs(low), abs(high)))
        word = "less" if low >= 0 else "more"
        return f"{head} ({100 * a:.1f}% to {100 * b:.1f}% {word})"
    return f"{head} ({_side(high)} to {_side(low)})"


COLORS = ("#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860")
# The three planners keep their colour in every figure (a kitchen curve of baseline and learned
# and a Panda curve of all three draw learned alike); other planners take the rest in order.
NAMED_COLORS = {"baseline": COLORS[0], "paper": COLORS[1], "learned": COLORS[2]}


def planner_colors(planners: Sequence[str]) -> dict[str, str]:
    """A colour per planner: the named planners' own, then the remaining colours in turn."""
    rest = [c for c in COLORS if c not in NAMED_COLORS.values()]
    others = [p for p in dict.fromkeys(planners) if p not in NAMED_COLORS]
    return {
        p: NAMED_COLORS[p] if p in NAMED_COLORS else rest[others.index(p) % len(rest)]
        for p in planners
    }


def figure_title(pts: Sequence[Point]) -> str:
    """``kitchen: baseline, learned, 4 seeds a scene``: the scenes' family (their names
    without the number), the planners and the seeds."""
    families = dict.fromkeys(re.sub(r"-?\d+$", "", p.scene) for p in pts)
    seeds = sorted({p.seeds for p in pts})
    count = f"{seeds[0]}" if len(seeds) == 1 else f"{seeds[0]} to {seeds[-1]}"
    unit = "seed" if seeds == [1] else "seeds"
    return f"{', '.join(families)}: {', '.join(_planners(pts))}, {count} {unit} a scene"


def figure_html(pts: Sequence[Point], title: str) -> str:
    """The two panels as a plotly page (its JS inline)."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    fig = make_subplots(
        rows=1,
        cols=2,
        subplot_titles=("planning s (timeouts at the budget)", "total s (planning + execution)"),
    )
    colors = planner_colors(_planners(pts))
    for planner in _planners(pts):
        mine = sorted((p for p in pts if p.planner == planner), key=lambda p: p.objects)
        for col, measure in enumerate(MEASURES, start=1):
            values = [getattr(p, measure) for p in mine]
            fig.add_trace(
                go.Scatter(
                    x=[p.objects for p in mine],
                    y=[v[0] for v in values],
                    error_y={
                        "type": "data",
                        "symmetric": False,
                        "array": [v[2] - v[0] for v in values],
                        "arrayminus": [v[0] - v[1] for v in values],
                    },
                    mode="lines+markers",
                    name=planner,
                    legendgroup=planner,
                    showlegend=col == 1,
                    line={"color": colors[planner]},
                    text=[f"{p.scene}: {p.solved}/{p.seeds} solved" for p in mine],
                ),
                row=1,
                col=col,
            )
        split = [p for p in mine if p.skeleton is not None]
        if split:  # planning's part spent on skeletons, dashed under the planning curve
            fig.add_trace(
                go.Scatter(
                    x=[p.objects for p in split],
                    y=[p.skeleton[0] for p in split if p.skeleton is not None],
                    mode="lines",
                    name=f"{planner}: skeletons",
                    legendgroup=planner,
                    line={"color": colors[planner], "dash": "dash"},
                ),
                row=1,
                col=1,
            )
    fig.update_xaxes(title_text="objects in the goal", tickvals=sorted({p.objects for p in pts}))
    fig.update_yaxes(title_text="seconds", rangemode="tozero")
    fig.update_layout(title=title, height=460)
    return str(fig.to_html(include_plotlyjs=True, full_html=True))


def figure_svg(pts: Sequence[Point], title: str, *, width: int = 900, height: int = 380) -> str:
    """The two panels as a plain SVG: each planner's means joined by lines, the intervals as
    bars, a legend; for docs, where a page cannot run plotly."""
    planners = _planners(pts)
    colors = planner_colors(planners)
    xs = sorted({p.objects for p in pts})
    margin_l, margin_r, margin_t, margin_b, gap = 60, 20, 50, 60, 60
    panel_w = (width - margin_l - margin_r - gap) / 2
    panel_h = height - margin_t - margin_b
    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
        f'viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="12">',
        f'<rect width="{width}" height="{height}" fill="white"/>',
        f'<text x="{width / 2}" y="20" text-anchor="middle" font-size="14">'
        f"{html.escape(title)}</text>",
    ]
    for k, measure in enumerate(MEASURES):
        x0 = margin_l + k * (panel_w + gap)
        top = max(v for p in pts for v in getattr(p, measure)) or 1.0
        top = _nice(top)

        def sx(value: float, x0: float = x0) -> float:
            if len(xs) == 1:
                return x0 + panel_w / 2
            pad = 0.06 * panel_w  # the first and last points off the panel's edges
            return x0 + pad + (value - xs[0]) / (xs[-1] - xs[0]) * (panel_w - 2 * pad)

        def sy(value: float, top: float = top) -> float:
            return margin_t + panel_h - value / top * panel_h

        label = "planning s (timeouts at the budget)" if measure == "planning" else "total s"
        parts.append(
            f'<text x="{x0 + panel_w / 2}" y="{margin_t - 12}" text-anchor="middle">{label}</text>'
        )
        parts.append(
            f'<rect x="{x0}" y="{margin_t}" width="{panel_w}" height="{panel_h}" '
            'fill="none" stroke="#999"/>'
        )
        for j in range(5):
            v = top * j / 4
            y = sy(v)
            parts.append(
                f'<line x1="{x0}" x2="{x0 + panel_w}" y1="{y:.1f}" y2="{y:.1f}" stroke="#eee"/>'
            )
            parts.append(f'<text x="{x0 - 6}" y="{y + 4:.1f}" text-anchor="end">{v:g}</text>')
        for x in xs:
            parts.append(
                f'<text x="{sx(x):.1f}" y="{margin_t + panel_h + 16}" '
                f'text-anchor="middle">{x}</text>'
            )
        parts.append(
            f'<text x="{x0 + panel_w / 2}" y="{margin_t + panel_h + 31}" '
            'text-anchor="middle">objects in the goal</text>'
        )
        for i, planner in enumerate(planners):
            color = colors[planner]
            mine = sorted((p for p in pts if p.planner == planner), key=lambda p: p.objects)
            shift = (i - (len(planners) - 1) / 2) * 4  # side by side, so bars do not hide
            line = " ".join(
                f"{sx(p.objects) + shift:.1f},{sy(getattr(p, measure)[0]):.1f}" for p in mine
            )
            parts.append(
                f'<polyline points="{line}" fill="none" stroke="{color}" stroke-width="2"/>'
            )
            split = [p for p in mine if p.skeleton is not None]
            if measure == "planning" and split:  # planning's part spent on skeletons
                dashed = " ".join(
                    f"{sx(p.objects) + shift:.1f},{sy(p.skeleton[0]):.1f}"
                    for p in split
                    if p.skeleton is not None
                )
                parts.append(
                    f'<polyline points="{dashed}" fill="none" stroke="{color}" '
                    'stroke-width="1.5" stroke-dasharray="5,4"/>'
                )
            for p in mine:
                mean, low, high = getattr(p, measure)
                cx = sx(p.objects) + shift
                parts.append(
                    f'<line x1="{cx:.1f}" x2="{cx:.1f}" y1="{sy(low):.1f}" y2="{sy(high):.1f}" '
                    f'stroke="{color}"/>'
                )
                parts.append(
                    f'<circle cx="{cx:.1f}" cy="{sy(mean):.1f}" r="3.5" fill="{color}">'
                    f"<title>{html.escape(p.scene)} {html.escape(planner)}: {mean:.1f} s "
                    f"({low:.1f} to {high:.1f}), {p.solved}/{p.seeds} solved</title></circle>"
                )
    legend_x = margin_l
    for i, planner in enumerate(planners):
        color = colors[planner]
        x = legend_x + i * 150
        y = height - 8
        parts.append(f'<rect x="{x}" y="{y - 5}" width="14" height="3" fill="{color}"/>')
        parts.append(f'<text x="{x + 20}" y="{y}">{html.escape(planner)}</text>')
    if any(p.skeleton is not None for p in pts):
        x = legend_x + len(planners) * 150
        parts.append(
            f'<line x1="{x}" x2="{x + 14}" y1="{height - 12}" y2="{height - 12}" stroke="#555" '
            'stroke-dasharray="4,3"/>'
        )
        parts.append(f'<text x="{x + 20}" y="{height - 8}">of which skeletons (dashed)</text>')
    parts.append("</svg>")
    return "\n".join(parts) + "\n"


def _nice(value: float) -> float:
    """A round axis top at or above ``value``."""
    exp = 10.0 ** math.floor(math.log10(value))
    for step in (1.0, 2.0, 2.5, 5.0, 10.0):
        if step * exp >= value:
            return step * exp
    return 10.0 * exp


def write(pts: Sequence[Point], out: Path, *, title: str) -> list[Path]:
    """The figure as ``out`` (.html: plotly; .svg: plain) and the points beside it as JSON."""
    if out.suffix not in (".html", ".svg"):
        raise ValueError(f"--out {out}: expected a .html or .svg file")
    out.parent.mkdir(parents=True, exist_ok=True)
    text = figure_html(pts, title) if out.suffix == ".html" else figure_svg(pts, title)
    out.write_text(text, encoding="utf-8")
    data = out.with_suffix(".json")
    data.write_text(json.dumps([p.to_dict() for p in pts], indent=1) + "\n", encoding="utf-8")
    return [out, data]
