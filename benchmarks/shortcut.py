"""Benchmark: the step-bounded path shortener against OMPL's time-limited simplifier.

    .venv/bin/python benchmarks/shortcut.py BENCH_ID --db bench-k4.db --trials 10

Replays the base moves of a kitchen benchmark's solved trials (first to last pose of every base
segment of the stored plans, with the trial's blocks at their initial poses and nothing held).
Each move that is not straight gets one RRT-Connect path, and a copy of that same path goes to
each shortener, so the comparison is paired: ``simplify`` is OMPL's
``PathSimplifier.simplify(path, 0.5 s)`` (what ``SimpleSetup.simplifySolution`` runs, and the
motion planner's shortener before), ``shorten`` is :func:`planner.sim.motion.shorten` with the
default steps. Prints the seconds of base travel (0.5 m/s, 1 rad/s) and the wall seconds spent
shortening, and the paired ratios with bootstrap 95% intervals over moves.
"""

from __future__ import annotations

import argparse
import logging
import random
import sys
import time

import numpy as np
from ompl import geometric as og

from planner.domains.kitchen.geometry import geometry_from_scene
from planner.domains.kitchen.samplers import KitchenSamplers, SamplerConfig, _base_duration
from planner.domains.kitchen.values import Conf
from planner.scene import load_scene
from planner.sim.motion import (
    MotionConfig,
    NoPath,
    base_problem,
    rough_path,
    seed_ompl,
    shorten,
)
from planner.sim.pr2_model import REST_ARM_CONF
from planner.store import RunStore
from planner.store.db import BenchRecord, BenchTrialRecord

log = logging.getLogger(__name__)

BaseMove = tuple[tuple[float, float, float], tuple[float, float, float]]


def base_moves(plan: dict) -> list[BaseMove]:  # type: ignore[type-arg]
    """First and last pose of every base segment of a stored kitchen plan."""
    moves: list[BaseMove] = []
    for value in plan.get("values", {}).values():
        if isinstance(value, dict) and "segments" in value:
            for seg in value["segments"]:
                if seg["kind"] == "base":
                    moves.append((tuple(seg["base"][0]), tuple(seg["base"][-1])))
    return moves


def solved_trials(
    store: RunStore, bench_id: str, planner: str | None = None
) -> tuple[BenchRecord, list[BenchTrialRecord]] | None:
    """A benchmark and its solved trials (of ``planner``, if given), or None when the store has
    no such benchmark (the known ones are then listed on stderr)."""
    try:
        bench = store.get_bench(bench_id)
    except KeyError as exc:  # the message lists the known benchmarks
        print(exc.args[0], file=sys.stderr)
        return None
    trials = [
        t
        for t in store.bench_trials(bench_id)
        if t.status == "solved" and t.run_id is not None and planner in (None, t.planner)
    ]
    return bench, trials


def _seconds(path: og.PathGeometric) -> float:
    states = [path.getState(i) for i in range(path.getStateCount())]
    return _base_duration([(s.getX(), s.getY(), s.getYaw()) for s in states])


def _copy(si: object, path: og.PathGeometric) -> og.PathGeometric:
    out = og.PathGeometric(si)
    for i in range(path.getStateCount()):
        out.append(path.getState(i))
    return out


def _ratio(a: np.ndarray, b: np.ndarray, rng: np.random.Generator) -> tuple[float, float, float]:
    """mean(a) / mean(b) over paired moves, with a bootstrap 95% interval."""
    idx = rng.integers(0, len(a), size=(5000, len(a)))
    samples = a[idx].mean(axis=1) / b[idx].mean(axis=1)
    low, high = np.percentile(samples, [2.5, 97.5])
    return float(a.mean() / b.mean()), float(low), float(high)


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("bench_id")
    parser.add_argument("--db", required=True)
    parser.add_argument("--trials", type=int, default=10, help="solved trials to replay")
    parser.add_argument("--seed", type=int, default=1, help="OMPL seed")
    parser.add_argument("--steps", type=int, default=MotionConfig().shortcut_steps)
    args = parser.parse_args()
    if args.trials < 1 or args.steps < 0:
        parser.error("--trials must be at least 1 and --steps at least 0")
    with RunStore(args.db) as store:
        found = solved_trials(store, args.bench_id)
        if found is None:
            return 2
        bench, trials = found
        runs = [(t.seed, str(t.run_id)) for t in trials]
        plans = [(seed, store.get_run(run_id).plan) for seed, run_id in runs[: args.trials]]
    geometry = geometry_from_scene(load_scene(bench.config["scene"]))
    samplers = KitchenSamplers(geometry, random.Random(0))
    world, rest = samplers.world, REST_ARM_CONF[samplers.arm]
    clearance = SamplerConfig().clearance
    config = MotionConfig(shortcut_steps=args.steps)
    seed_ompl(args.seed)

    def valid(base: tuple[float, float, float]) -> bool:
        world.set_conf(Conf(base, geometry.robot.torso, rest))
        return not world.robot_collides(clearance=clearance)

    rows: list[tuple[float, float, float, float, float]] = []  # raw, simplify s, t, shorten s, t
    straight = 0
    for seed, plan in plans:
        world.hold(None)
        world.set_blocks(geometry.initial_poses(seed))
        for start, goal in base_moves(plan or {}):
            ss, s0, s1 = base_problem(start, goal, valid, samplers.bounds)
            found = rough_path(ss, s0, s1, config, None)
            if isinstance(found, NoPath) or not found[1]:
                straight += not isinstance(found, NoPath)
                continue
            raw, si = found[0], ss.getSpaceInformation()
            a, b = _copy(si, raw), _copy(si, raw)
            t0 = time.perf_counter()
            og.PathSimplifier(si).simplify(a, 0.5)
            t1 = time.perf_counter()
            b = shorten(si, b, config.shortcut_steps)
            t2 = time.perf_counter()
            rows.append((_seconds(raw), _seconds(a), t1 - t0, _seconds(b), t2 - t1))
        print(f"seed {seed}: {len(rows)} planned moves so far", file=sys.stderr)
    if not rows:
        print("no base move needed planning", file=sys.stderr)
        return 1
    m = np.asarray(rows)
    rng = np.random.default_rng(0)
    print(f"{len(plans)} trials, {len(rows)} planned base moves ({straight} straight, skipped)")
    print("| shortener | base travel s / move | wall s / move |")
    print("| --- | --- | --- |")
    print(f"| none (RRT-Connect) | {m[:, 0].mean():.2f} | - |")
    print(f"| simplify(0.5 s) | {m[:, 1].mean():.2f} | {m[:, 2].mean():.3f} |")
    steps = config.shortcut_steps
    print(f"| shorten({steps} steps) | {m[:, 3].mean():.2f} | {m[:, 4].mean():.3f} |")
    for name, i, j in (("travel", 3, 1), ("wall", 4, 2)):
        r, lo, hi = _ratio(m[:, i], m[:, j], rng)
        print(f"shorten / simplify {name}: {r:.3f} (95% CI {lo:.3f} to {hi:.3f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
