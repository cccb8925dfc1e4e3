"""Benchmark: what shortening an arm path costs in planning and saves in execution.

    .venv/bin/python benchmarks/arm_shortcut.py --scene kitchen-4 --seeds 1003-1004 \\
        --planner baseline --steps 0,10,25,50,100

Runs real kitchen runs (one fresh process per seed, the search unchanged: every arm path it
plans is shortened with the sampler's own setting). Each arm path that RRT-Connect had to plan
(straight moves need no shortening) is also shortened, from a copy of the same rough path and
in the same world, with each of ``--steps`` partial shortcuts (:func:`planner.sim.motion
.shorten`), so the comparison is paired. Prints per setting the mean execution seconds of the
path (joint velocity limits) and the wall seconds of shortening it, and paired differences
against the sampler's setting with bootstrap 95% intervals. A path the robot executes costs
both; a path planned for a branch the search drops costs only the wall seconds.

    .venv/bin/python benchmarks/arm_shortcut.py --full 100,10 --seeds 1003-1008 --planner baseline

With ``--full A,B`` the seeds instead run whole searches with the arm paths shortened with A and
with B steps (the order of the two alternating from seed to seed, a fresh process per trial),
and it prints mean planning, execution and total seconds and the paired ratios B / A with
bootstrap 95% intervals over the seeds both solved.
"""

from __future__ import annotations

import argparse
import multiprocessing
import sys
import time
from typing import Any

import numpy as np


def seeds(text: str) -> list[int]:
    """LO-HI (or one seed) as a list; ValueError if it is not that."""
    lo, _, hi = text.partition("-")
    out = list(range(int(lo), int(hi or lo) + 1))
    if not out:
        raise ValueError(text)
    return out


def measure(scene: str, seed: int, planner: str, steps: list[int]) -> list[dict[int, Any]]:
    """Per planned arm path of one run: {steps: (execution s, wall s)}."""
    from ompl import geometric as og

    import planner.sim.motion as motion
    from planner.domains.kitchen.samplers import SamplerConfig, _arm_duration
    from planner.runs import RunConfig, preload_libraries, run
    from planner.sim.pr2_model import ARM_JOINTS

    joints = ARM_JOINTS["right"]  # the kitchen's samplers plan for the right arm
    dim = len(joints)
    used = SamplerConfig().arm_motion.shortcut_steps
    original = motion.shorten
    rows: list[dict[int, Any]] = []

    def seconds(path: og.PathGeometric) -> float:
        states = [path.getState(i) for i in range(path.getStateCount())]
        return _arm_duration([tuple(s[j] for j in range(dim)) for s in states], joints)

    def copy(si: Any, path: og.PathGeometric) -> og.PathGeometric:
        out = og.PathGeometric(si)
        for i in range(path.getStateCount()):
            out.append(path.getState(i))
        return out

    def paired(si: Any, path: og.PathGeometric, n: int) -> og.PathGeometric:
        if si.getStateSpace().getDimension() != dim:  # a base path: unchanged
            return original(si, path, n)
        row: dict[int, Any] = {}
        kept = None
        for s in sorted(set(steps) | {used}):
            p = copy(si, path)
            t = time.perf_counter()
            p = original(si, p, s)
            row[s] = (seconds(p), time.perf_counter() - t)
            if s == n:
                kept = p
        rows.append(row)
        return kept if kept is not None else original(si, path, n)

    motion.shorten = paired  # type: ignore[assignment]
    config = RunConfig(scene=scene, seed=seed, planner=planner)
    preload_libraries(config)
    result, _, _ = run(config)
    print(f"seed {seed}: {result.status}, {len(rows)} planned arm paths", file=sys.stderr)
    return rows


def full_trial(scene: str, seed: int, planner: str, steps: int, budget: float) -> dict[str, Any]:
    """One whole run with the arm paths shortened with ``steps`` partial shortcuts."""
    from dataclasses import replace

    from planner.api import solve
    from planner.domains import load_domain
    from planner.domains.kitchen import with_samplers
    from planner.domains.kitchen.samplers import SamplerConfig
    from planner.runs import RunConfig, preload_libraries

    base = SamplerConfig()
    config = replace(base, arm_motion=replace(base.arm_motion, shortcut_steps=steps))
    run_config = RunConfig(scene=scene, seed=seed, planner=planner, budget_s=budget)
    preload_libraries(run_config)
    result = solve(run_config, loaded=with_samplers(load_domain("kitchen"), config)).result
    return {
        "solved": result.solved,
        "planning": result.planning_s,
        "execution": result.execution_s,
        "motions": sum(q.stream == "plan-motion" for q in result.queries),
    }


def compare_full(args: argparse.Namespace, a: int, b: int) -> int:
    ctx = multiprocessing.get_context("spawn")
    out: dict[tuple[int, int], dict[str, Any]] = {}
    jobs = []
    for i, seed in enumerate(args.seed_list):
        jobs += [(seed, s) for s in ((a, b) if i % 2 == 0 else (b, a))]
    for n, (seed, s) in enumerate(jobs, 1):
        with ctx.Pool(1, maxtasksperchild=1) as pool:
            r = pool.apply(full_trial, (args.scene, seed, args.planner, s, args.budget))
        out[(seed, s)] = r
        total = f"{r['planning'] + r['execution']:.1f} s" if r["solved"] else "unsolved"
        print(f"[{n}/{len(jobs)}] seed {seed}, {s} steps: {total}", file=sys.stderr)
    both = [sd for sd in args.seed_list if out[(sd, a)]["solved"] and out[(sd, b)]["solved"]]
    print(f"{args.planner} on {args.scene} seeds {args.seeds}: {len(both)} solved with both")
    print("| arm steps | solved | planning s | execution s | total s | motion queries |")
    print("| --- | --- | --- | --- | --- | --- |")
    for s in (a, b):
        solved = sum(out[(sd, s)]["solved"] for sd in args.seed_list)
        rows = [out[(sd, s)] for sd in both]
        cells = [
            np.mean([r["planning"] for r in rows]),
            np.mean([r["execution"] for r in rows]),
            np.mean([r["planning"] + r["execution"] for r in rows]),
            np.mean([r["motions"] for r in rows]),
        ]
        print(
            f"| {s} | {solved}/{len(args.seed_list)} | "
            + " | ".join(f"{c:.1f}" for c in cells)
            + " |"
        )
    rng = np.random.default_rng(0)
    for key in ("planning", "execution", "total"):
        ratios = np.array([_value(out[(sd, b)], key) / _value(out[(sd, a)], key) for sd in both])
        if len(ratios):
            lo, hi = _interval(ratios, rng)
            print(f"{key}: {b} / {a} steps = {ratios.mean():.3f} (95% CI {lo:.3f} to {hi:.3f})")
    return 0


def _value(r: dict[str, Any], key: str) -> float:
    return float(r["planning"] + r["execution"]) if key == "total" else float(r[key])


def _interval(d: np.ndarray, rng: np.random.Generator) -> tuple[float, float]:
    idx = rng.integers(0, len(d), size=(5000, len(d)))
    lo, hi = np.percentile(d[idx].mean(axis=1), [2.5, 97.5])
    return float(lo), float(hi)


def main() -> int:
    from planner.domains.kitchen.samplers import SamplerConfig

    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--scene", default="kitchen-4")
    parser.add_argument("--seeds", default="1003-1004")
    parser.add_argument("--planner", default="baseline")
    parser.add_argument("--steps", default="0,10,25,50,100", help="comma-separated settings")
    parser.add_argument("--full", default=None, help="A,B: whole runs with A and with B steps")
    parser.add_argument("--budget", type=float, default=300.0, help="with --full")
    args = parser.parse_args()
    try:
        args.seed_list = seeds(args.seeds)
    except ValueError:
        parser.error("--seeds takes LO-HI or one seed (integers, LO <= HI)")
    if args.full is not None:
        try:
            a, b = (int(x) for x in args.full.split(","))
        except ValueError:
            parser.error("--full takes two step counts, A,B")
        if min(a, b) < 0 or args.budget <= 0:
            parser.error("--full needs step counts >= 0 and a positive --budget")
        return compare_full(args, a, b)
    try:
        steps = sorted({int(s) for s in args.steps.split(",")})
    except ValueError:
        parser.error("--steps must be comma-separated integers")
    if any(s < 0 for s in steps):
        parser.error("--steps must be at least 0")
    used = SamplerConfig().arm_motion.shortcut_steps
    ctx = multiprocessing.get_context("spawn")  # OMPL takes one seed per process
    rows: list[dict[int, Any]] = []
    for seed in args.seed_list:
        with ctx.Pool(1) as pool:
            rows += pool.apply(measure, (args.scene, seed, args.planner, steps))
    if not rows:
        print("no arm path needed planning", file=sys.stderr)
        return 1
    rng = np.random.default_rng(0)
    print(f"{len(rows)} planned arm paths, {args.planner} on {args.scene} seeds {args.seeds}")
    head = (
        f"| steps | execution s / path | wall s / path | vs {used}: execution | vs {used}: wall |"
    )
    print(head)
    print("| --- | --- | --- | --- | --- |")
    base = np.array([[r[used][0], r[used][1]] for r in rows])
    for s in sorted(set(steps) | {used}):
        m = np.array([[r[s][0], r[s][1]] for r in rows])
        cells = [f"{m[:, 0].mean():.3f}", f"{m[:, 1].mean():.3f}"]
        for i in (0, 1):
            d = m[:, i] - base[:, i]
            lo, hi = _interval(d, rng)
            cells.append(f"{d.mean():+.3f} ({lo:+.3f} to {hi:+.3f})")
        print(f"| {s} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
