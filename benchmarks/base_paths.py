"""Benchmark: how much shorter could the base moves of executed kitchen plans be?

    .venv/bin/python benchmarks/base_paths.py BENCH_ID --db bench-k4.db --trials 10 \
        --planner learned --tries 4 --rrtstar-s 5

Replays the plans that a kitchen benchmark's solved trials stored, action by action: before
each move the blocks stand where the plan has put them so far and the held block is in the
hand, as when the planner planned that move. Each base move (first to last pose of its base
segment) that is not a free straight line is then planned again in that world, paired:

- N fresh runs of the planner's own base motion (RRT-Connect, 1 s, then the shipped
  shortening). Keeping the shortest of the executed path and these is what re-sampling a
  motion N more times would buy, at the wall seconds shown. The first fresh path against the
  executed one checks the replay: their ratio should be about 1.
- OMPL's asymptotically optimal RRT* given T seconds (path length objective), then the same
  shortening, kept where it is shorter than the executed path.
- The straight line from start to goal, ignoring collisions (0.5 m/s or 1 rad/s, whichever
  is longer), bounds every path from below.

Prints the mean base seconds per planned move with paired ratios to the executed path
(bootstrap 95% intervals over moves), and per trial the execution seconds each way saves and
the planning seconds it costs (intervals over trials).
"""

from __future__ import annotations

import argparse
import logging
import math
import random
import sys
import time
from collections.abc import Iterator
from typing import Any

import numpy as np
from ompl import geometric as og
from shortcut import _ratio, _seconds, solved_trials

from planner.domains import load_domain
from planner.domains.kitchen.geometry import BlockPose, geometry_from_scene
from planner.domains.kitchen.samplers import KitchenSamplers, SamplerConfig, _base_duration
from planner.domains.kitchen.values import Conf, Grasp, Trajectory
from planner.scene import load_scene
from planner.sim.motion import NoPath, base_problem, rough_path, seed_ompl, shorten
from planner.sim.pr2_model import REST_ARM_CONF
from planner.store import RunStore

log = logging.getLogger(__name__)

BaseConf = tuple[float, float, float]
# (blocks on their poses, held block and grasp, start, goal, executed seconds) of one move
Move = tuple[dict[str, BlockPose], tuple[str, Grasp] | None, BaseConf, BaseConf, float]


def plan_moves(plan: dict[str, Any], initial: dict[str, BlockPose]) -> Iterator[Move]:
    """The base moves of a stored plan, each with the world as it is when the robot makes it."""
    kitchen = load_domain("kitchen")
    values = {name: kitchen.decode(v, name) for name, v in plan.get("values", {}).items()}
    poses = dict(initial)
    held: tuple[str, Grasp] | None = None
    for text in plan.get("actions", []):
        name, *args = text.strip("()").split()
        if name == "move":
            traj = values.get(args[2])
            if not isinstance(traj, Trajectory):
                raise ValueError(f"{text}: no trajectory stored for {args[2]}")
            for seg in traj.segments:
                if seg.kind == "base":
                    yield dict(poses), held, seg.base[0], seg.base[-1], seg.seconds
        elif name == "pick":
            grasp = values.get(args[3])
            if not isinstance(grasp, Grasp):
                raise ValueError(f"{text}: no grasp stored for {args[3]}")
            poses.pop(args[0], None)
            held = (args[0], grasp)
        elif name in ("place", "cook"):
            pose = values.get(args[1])
            if not isinstance(pose, BlockPose):
                raise ValueError(f"{text}: no pose stored for {args[1]}")
            poses[args[0]] = pose
            held = None


def _bootstrap_mean(x: np.ndarray, rng: np.random.Generator) -> tuple[float, float, float]:
    idx = rng.integers(0, len(x), size=(5000, len(x)))
    low, high = np.percentile(x[idx].mean(axis=1), [2.5, 97.5])
    return float(x.mean()), float(low), float(high)


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("bench_id")
    parser.add_argument("--db", required=True)
    parser.add_argument("--trials", type=int, default=10, help="solved trials to replay")
    parser.add_argument("--planner", default="learned", help="whose plans to replay")
    parser.add_argument("--tries", type=int, default=4, help="RRT-Connect runs per move")
    parser.add_argument("--rrtstar-s", type=float, default=5.0, help="RRT* seconds per move")
    parser.add_argument("--seed", type=int, default=1, help="OMPL seed")
    args = parser.parse_args()
    if args.trials < 1 or args.tries < 1 or args.rrtstar_s <= 0:
        parser.error("--trials and --tries must be at least 1 and --rrtstar-s positive")
    with RunStore(args.db) as store:
        found = solved_trials(store, args.bench_id, args.planner)
        if found is None:
            return 2
        bench, trials = found[0], found[1][: args.trials]
        plans = [(t.seed, t.execution_s, store.get_run(str(t.run_id)).plan) for t in trials]
    if not plans:
        print(f"no solved {args.planner} trial in benchmark {args.bench_id}", file=sys.stderr)
        return 1
    geometry = geometry_from_scene(load_scene(bench.config["scene"]))
    samplers = KitchenSamplers(geometry, random.Random(0))
    world, rest = samplers.world, REST_ARM_CONF[samplers.arm]
    clearance = SamplerConfig().clearance
    config = SamplerConfig().motion
    seed_ompl(args.seed)

    def valid(base: BaseConf) -> bool:
        world.set_conf(Conf(base, geometry.robot.torso, rest))
        return not world.robot_collides(clearance=clearance)

    # per planned move: bound, executed, N fresh RRT-Connect tries (inf: none found), RRT*
    # (inf: none found); wall seconds of each try and of RRT*
    rows: list[list[float]] = []
    walls: list[list[float]] = []
    trial_of: list[int] = []  # index into plans of each row
    straight = 0
    for k, (seed, _, plan) in enumerate(plans):
        for poses, held, start, goal, executed in plan_moves(
            plan or {}, geometry.initial_poses(seed)
        ):
            world.hold(None)
            world.set_blocks(poses)
            if held is not None:
                world.hold(*held)
            secs: list[float] = []
            spent: list[float] = []
            for _ in range(args.tries):
                t0 = time.perf_counter()
                ss, s0, s1 = base_problem(start, goal, valid, samplers.bounds)
                found = rough_path(ss, s0, s1, config, None)
                if isinstance(found, NoPath):
                    spent.append(time.perf_counter() - t0)
                    secs.append(math.inf)
                    continue
                if not found[1]:
                    break  # the straight line is free
                path = shorten(ss.getSpaceInformation(), found[0], config.shortcut_steps)
                spent.append(time.perf_counter() - t0)
                secs.append(_seconds(path))
            if not secs:
                straight += 1
                continue
            t0 = time.perf_counter()
            ss, s0, s1 = base_problem(start, goal, valid, samplers.bounds)
            si = ss.getSpaceInformation()
            si.setStateValidityCheckingResolution(config.resolution)
            si.setup()
            ss.setPlanner(og.RRTstar(si))
            star = math.inf
            if ss.solve(args.rrtstar_s) and ss.haveExactSolutionPath():
                star = _seconds(shorten(si, ss.getSolutionPath(), config.shortcut_steps))
            spent.append(time.perf_counter() - t0)
            rows.append([_base_duration([start, goal]), executed, *secs, star])
            walls.append(spent)
            trial_of.append(k)
        print(f"seed {seed}: {len(rows)} planned base moves so far", file=sys.stderr)
    if not rows:
        print("no base move needed planning", file=sys.stderr)
        return 1
    m, w = np.asarray(rows), np.asarray(walls)
    rng = np.random.default_rng(0)
    n = args.tries
    executed = m[:, 1]
    tries, star = m[:, 2 : 2 + n], m[:, 2 + n]
    fresh = np.isfinite(tries[:, 0])
    print(
        f"{bench.config['scene']}, {len(plans)} {args.planner} trials, {len(rows)} planned base "
        f"moves ({straight} straight, not planned); RRT-Connect found no path in "
        f"{int((~np.isfinite(tries)).sum())} of {tries.size} tries, RRT* in "
        f"{int((~np.isfinite(star)).sum())} of {len(star)} moves"
    )
    r, lo, hi = _ratio(tries[fresh, 0], executed[fresh], rng)
    print(
        f"replay check: a fresh RRT-Connect path / the executed one = {r:.3f} "
        f"(95% CI {lo:.3f} to {hi:.3f}) over {int(fresh.sum())} moves"
    )
    print(
        "\n| base path, keeping the executed one where it is shorter | s / move | "
        "vs executed (95% CI) | extra wall s / move |"
    )
    print("| --- | --- | --- | --- |")
    ways = [
        ("executed", executed, None),
        ("1 more RRT-Connect sample", np.minimum(executed, tries[:, 0]), w[:, 0]),
        (
            f"{n} more RRT-Connect samples",
            np.minimum(executed, tries.min(axis=1)),
            w[:, :n].sum(axis=1),
        ),
        (f"RRT* {args.rrtstar_s:g} s", np.minimum(executed, star), w[:, n]),
        ("straight-line bound (ignores collisions)", m[:, 0], None),
    ]
    for name, secs_, wall in ways:
        r, lo, hi = _ratio(secs_, executed, rng)
        cell = "-" if wall is None else f"{wall.mean():.2f}"
        print(f"| {name} | {secs_.mean():.2f} | {r:.3f} ({lo:.3f} to {hi:.3f}) | {cell} |")
    execution = np.asarray([e or 0.0 for _, e, _ in plans])
    owner = np.asarray(trial_of)
    print(f"\nper trial: mean execution {execution.mean():.1f} s; seconds saved:")
    for name, secs_, wall in ways[1:4]:
        saved = np.bincount(owner, executed - secs_, minlength=len(plans))
        cost = np.bincount(owner, wall, minlength=len(plans))
        s, slo, shi = _bootstrap_mean(saved, rng)
        print(
            f"  {name}: {s:.1f} s (95% CI {slo:.1f} to {shi:.1f}), "
            f"{100 * s / execution.mean():.1f}% of execution, for {cost.mean():.1f} s of planning"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
