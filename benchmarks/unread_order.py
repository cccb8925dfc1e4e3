"""Probe: does the model order's ``DomainSpec.unread`` change the learned planner's execution?

    .venv/bin/python benchmarks/unread_order.py --scene kitchen-8 --seeds 1012-1035 --budget 600 \
        [--base-order straight]

Runs the learned planner on the same seeds twice, once with the domain's ``unread`` (the
default since 2cef2e3: every placement before any IK) and once without it (each placement after
the grasp and IK its context names, as at 671f94b), the two alternating their order from seed to
seed, two workers, a fresh interpreter per trial. Prints each trial and, over the seeds both
solved, the paired mean difference of execution seconds (with unread minus without) with a
bootstrap 95% interval, how many seeds it is positive on, and the mean planning seconds and
queries of each setting. ``--base-order straight`` gives IK's base poses the order they had
before 1110744 (so the runs are those of 3ed1992).
"""

from __future__ import annotations

import argparse
import logging
import multiprocessing
import random
import statistics
import sys
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from typing import Any

SETTINGS = ("unread", "all")  # "all": the order waits for every fluent's objects


def _trial(job: tuple[str, int, str, float, str]) -> dict[str, Any]:
    scene, seed, setting, budget, base_order = job
    import planner.domains.kitchen.samplers as ks
    from planner.api import RunConfig, solve
    from planner.domains import load_domain

    config = replace(ks.SamplerConfig(), base_order=base_order)
    init = ks.KitchenSamplers.__init__

    def with_order(self: Any, geometry: Any, rng: random.Random, **kw: Any) -> None:
        kw.setdefault("config", config)
        init(self, geometry, rng, **kw)

    ks.KitchenSamplers.__init__ = with_order  # type: ignore[method-assign]

    kitchen = load_domain("kitchen")
    if setting == "all":  # the kitchen with no unread hint: the order waits for every fluent
        kitchen = replace(kitchen, spec=replace(kitchen.spec, unread={}))
    result = solve(
        RunConfig(scene=scene, seed=seed, planner="learned", budget_s=budget), loaded=kitchen
    ).result
    return {
        "seed": seed,
        "setting": setting,
        "status": result.status,
        "planning": result.planning_s,
        "execution": result.execution_s,
        "queries": len(result.queries),
    }


def _parse_seeds(text: str) -> list[int]:
    if "-" in text:
        lo, hi = (int(x) for x in text.split("-", 1))
        return list(range(lo, hi + 1))
    return [int(x) for x in text.split(",")]


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--scene", default="kitchen-8")
    parser.add_argument("--seeds", default="1012-1035", help="range LO-HI or a list a,b,c")
    parser.add_argument("--budget", type=float, default=600.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--base-order", default="around", help="SamplerConfig.base_order")
    args = parser.parse_args()
    try:
        seeds = _parse_seeds(args.seeds)
    except ValueError:
        parser.error("--seeds takes LO-HI or a,b,c (integers)")
    if not seeds or args.workers < 1 or args.budget <= 0:
        parser.error("need seeds, a positive budget and workers >= 1")
    from planner.domains.kitchen.samplers import BASE_ORDERS

    if args.base_order not in BASE_ORDERS:
        parser.error(f"--base-order takes one of {', '.join(BASE_ORDERS)}")
    logging.basicConfig(level=logging.WARNING)
    jobs = []
    for i, seed in enumerate(seeds):
        order = SETTINGS if i % 2 == 0 else SETTINGS[::-1]
        jobs += [(args.scene, seed, s, args.budget, args.base_order) for s in order]
    trials: dict[tuple[int, str], dict[str, Any]] = {}
    ctx = multiprocessing.get_context("spawn")  # OMPL takes one seed per process
    with ProcessPoolExecutor(args.workers, mp_context=ctx, max_tasks_per_child=1) as pool:
        for n, t in enumerate(pool.map(_trial, jobs), 1):
            trials[(t["seed"], t["setting"])] = t
            print(
                f"[{n}/{len(jobs)}] seed {t['seed']} {t['setting']}: {t['status']}, "
                f"planning {t['planning']:.1f} s, execution {t['execution'] or 0:.1f} s",
                file=sys.stderr,
            )
    both = [s for s in seeds if all(trials[(s, c)]["execution"] is not None for c in SETTINGS)]
    if not both:
        print("no seed solved by both settings")
        return 1
    diff = [trials[(s, "unread")]["execution"] - trials[(s, "all")]["execution"] for s in both]
    rng = random.Random(0)
    means = sorted(statistics.mean(rng.choices(diff, k=len(diff))) for _ in range(4000))
    print(f"{args.scene}, learned, seeds {seeds[0]}-{seeds[-1]}: {len(both)} solved by both")
    print(
        f"execution, with unread - without: {statistics.mean(diff):+.1f} s "
        f"(95% CI {means[100]:+.1f} to {means[3899]:+.1f}), positive on {sum(d > 0 for d in diff)}"
        + (f", SD {statistics.stdev(diff):.1f} s" if len(diff) > 1 else "")
    )
    for c in SETTINGS:
        planning = statistics.mean(trials[(s, c)]["planning"] for s in both)
        queries = statistics.mean(trials[(s, c)]["queries"] for s in both)
        print(f"{c}: planning {planning:.1f} s, {queries:.1f} queries")
    return 0


if __name__ == "__main__":
    sys.exit(main())
