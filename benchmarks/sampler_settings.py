"""Benchmark: the kitchen's sampler settings compared, paired on the same seeds.

    .venv/bin/python benchmarks/sampler_settings.py --scene kitchen-4 --seeds 2000-2011 \
        --planner baseline --budget 300 --workers 2 --field ik_attempts --settings 12,96

Runs the same seeds with each value of ``--settings`` for one field of the kitchen's
``SamplerConfig`` (``--field``, any number or text field: ``ik_attempts``, ``placement_attempts``,
``base_order``, ...; default ``base_order`` with "straight,around"), set through
``planner.domains.kitchen.with_samplers``, a fresh process per trial, the settings' order
rotating from seed to seed so that machine noise hits them alike. Prints, per setting, solved
trials and the mean planning, execution, total, base travel, arm and straight-line-bound seconds
and query and motion-query counts over the seeds every setting solved, and the paired ratios
against the first setting with bootstrap 95% intervals.
"""

from __future__ import annotations

import argparse
import logging
import math
import multiprocessing
import random
import statistics
import sys
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from _common import parse_seeds

from planner.robots.pr2.model import BASE_VELOCITY
from planner.runs import PLANNERS, RunConfig
from planner.sim.transforms import wrap_angle


def _breakdown(values: dict[str, Any]) -> tuple[float, float, float]:
    """(base seconds, arm seconds, straight-line bound of the base moves) of bound values."""
    from planner.domains.kitchen.values import Trajectory

    linear, angular = BASE_VELOCITY
    base = arm = bound = 0.0
    for value in values.values():
        if not isinstance(value, Trajectory):
            continue
        for seg in value.segments:
            if seg.kind == "base":
                base += seg.seconds
                a, b = seg.base[0], seg.base[-1]
                bound += max(
                    math.dist(a[:2], b[:2]) / linear, abs(wrap_angle(b[2] - a[2])) / angular
                )
            else:
                arm += seg.seconds
    return base, arm, bound


def _config(field: str, setting: str) -> Any:
    """The default ``SamplerConfig`` with ``field`` set from the text ``setting``."""
    from planner.domains.kitchen.samplers import SamplerConfig

    return SamplerConfig().with_text(field, setting)


def _trial(
    job: tuple[str, int, str, str, str, float],
) -> tuple[int, str, dict[str, float] | None]:
    scene, seed, field, setting, planner, budget = job
    from planner.api import solve
    from planner.domains import load_domain
    from planner.domains.kitchen import with_samplers

    kitchen = with_samplers(load_domain("kitchen"), _config(field, setting))
    cfg = RunConfig(scene=scene, seed=seed, planner=planner, budget_s=budget)
    result = solve(cfg, loaded=kitchen).result
    if result.bound is None or result.execution_s is None:
        return seed, setting, None
    base, arm, bound = _breakdown(dict(result.bound.values))
    return (
        seed,
        setting,
        {
            "planning": result.planning_s,
            "execution": result.execution_s,
            "total": result.planning_s + result.execution_s,
            "base": base,
            "arm": arm,
            "bound": bound,
            "queries": float(len(result.queries)),
            "motions": float(sum(q.stream == "plan-motion" for q in result.queries)),
        },
    )


def _ci(ratios: list[float], rng: random.Random, n: int = 2000) -> tuple[float, float]:
    means = sorted(statistics.mean(rng.choices(ratios, k=len(ratios))) for _ in range(n))
    return means[int(0.025 * n)], means[int(0.975 * n) - 1]


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--scene", default="kitchen-4")
    parser.add_argument("--seeds", default="2000-2009", help="range LO-HI or a list a,b,c")
    parser.add_argument("--planner", default="baseline", choices=PLANNERS)
    parser.add_argument("--budget", type=float, default=300.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--field", default="base_order", help="the SamplerConfig field to vary")
    parser.add_argument(
        "--settings", default="straight,around", help="its values, the first the reference"
    )
    args = parser.parse_args()
    try:
        seeds = parse_seeds(args.seeds)
    except ValueError:
        parser.error("--seeds takes LO-HI or a,b,c (integers)")
    if not seeds or args.workers < 1 or args.budget <= 0:
        parser.error("need seeds, a positive budget and workers >= 1")

    settings = args.settings.split(",")
    if len(settings) < 2:
        parser.error("--settings takes two or more values, comma-separated")
    for setting in settings:
        try:
            _config(args.field, setting)
        except ValueError as exc:
            parser.error(f"--field {args.field!r} --settings {setting!r}: {exc}")
    logging.basicConfig(level=logging.WARNING)
    jobs = []
    for i, seed in enumerate(seeds):
        k = i % len(settings)
        order = settings[k:] + settings[:k]
        jobs += [(args.scene, seed, args.field, c, args.planner, args.budget) for c in order]
    results: dict[tuple[int, str], dict[str, float] | None] = {}
    # A fresh interpreter per trial: OMPL takes one seed per process, so a reused worker would
    # plan each later trial from wherever the first one left its random generator.
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(args.workers, mp_context=ctx, max_tasks_per_child=1) as pool:
        for n, (seed, setting, figures) in enumerate(pool.map(_trial, jobs), 1):
            results[(seed, setting)] = figures
            got = "unsolved" if figures is None else f"total {figures['total']:.1f} s"
            print(f"[{n}/{len(jobs)}] seed {seed} {setting}: {got}", file=sys.stderr)
    both = [s for s in seeds if all(results.get((s, c)) for c in settings)]
    print(f"{args.scene}, {args.planner}, seeds {seeds[0]}-{seeds[-1]}; {len(both)} solved by all")
    keys = ("planning", "execution", "total", "base", "arm", "bound", "queries", "motions")
    print(f"| {args.field} | solved | " + " | ".join(keys) + " |")
    print("|---" * (len(keys) + 2) + "|")
    for c in settings:
        solved = sum(results.get((s, c)) is not None for s in seeds)
        means = [statistics.mean(results[(s, c)][k] for s in both) for k in keys]  # type: ignore[index]
        cells = " | ".join(f"{m:.1f}" for m in means)
        print(f"| {c} | {solved}/{len(seeds)} | {cells} |")
    rng = random.Random(0)
    ref = settings[0]
    for c in settings[1:]:
        for k in ("planning", "execution", "total", "base"):
            ratios = [results[(s, c)][k] / results[(s, ref)][k] for s in both]  # type: ignore[index]
            if not ratios:
                continue
            lo, hi = _ci(ratios, rng)
            mean = statistics.mean(ratios)
            print(f"{k}: {c} / {ref} = {mean:.3f} (95% CI {lo:.3f} to {hi:.3f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
