"""Benchmark: how many RRT-Connect iterations kitchen motion queries take, and at what rate.

    .venv/bin/python benchmarks/motion_iterations.py --scene kitchen-4 --seeds 3000-3003 \
        --planner baseline --budget 300

Runs whole trials one after the other in this process and records every RRT search that the
motion planner grows (moves whose straight line is free grow none): its state space (3
dimensions: the base; 7: an arm), how many times the planner checked its termination
condition (once per iteration), its wall seconds and whether it found a path. Prints, per
space, the percentiles of the iterations a found path took, how many searches stopped without
a path, for candidate iteration limits how many of the found paths they would have cut, and
the seconds an iteration costs (a least-squares line through every search's seconds). Run it
on an idle machine: that pace is how a limit in iterations translates into seconds.

Two versions of the code, paired on the same seeds:

    mkdir /tmp/before && git archive <rev> | tar -x -C /tmp/before
    .venv/bin/python benchmarks/motion_iterations.py --scene kitchen-4 --seeds 3000-3005 \
        --before /tmp/before

runs every seed's trial twice, each in a fresh process (OMPL takes one random seed per process,
so only a fresh process gives a trial its own motions): once with the planner package of the
tree at ``--before`` and once with this one, one after the other, which goes first alternating
from seed to seed so that a shared, noisy machine slows both alike. Prints each tree's seconds
per iteration for base and arm searches, their paired ratio (this tree / before, per seed:
median and range), and whether the two trees made the same searches (iterations, outcome) and
the same motions (every plan-motion query's trajectory, waypoint for waypoint).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import logging
import os
import statistics
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from _common import parse_seeds

from planner.domains.kitchen.samplers import SamplerConfig
from planner.runs import PLANNERS, RunConfig, run

HERE = Path(__file__).resolve().parents[1]  # this tree: the planner package "after"


@dataclass(frozen=True)
class Search:
    dims: int
    checks: int
    seconds: float
    solved: bool


@dataclass(frozen=True)
class Trial:
    """One trial's RRT searches and a digest of each plan-motion query's outcome."""

    seed: int
    solved: bool
    searches: list[Search]
    motions: list[str]  # per plan-motion query, in order: a hash of its trajectory, or why none


class _Recorder(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.searches: list[Search] = []

    def emit(self, record: logging.LogRecord) -> None:
        if "termination checks" in record.msg and isinstance(record.args, tuple):
            _, dims, checks, seconds, solved = record.args
            self.searches.append(Search(int(dims), int(checks), float(seconds), bool(solved)))


def _recorder() -> _Recorder:
    recorder = _Recorder()
    motion = logging.getLogger("planner.sim.motion")
    motion.setLevel(logging.DEBUG)
    motion.addHandler(recorder)
    return recorder


def _trial(recorder: _Recorder, scene: str, seed: int, planner: str, budget: float) -> Trial:
    first = len(recorder.searches)
    result, _, _ = run(RunConfig(scene=scene, seed=seed, planner=planner, budget_s=budget))
    motions = [
        hashlib.sha1(repr(q.outputs).encode()).hexdigest()[:16] if q.success else str(q.reason)
        for q in result.queries
        if q.stream == "plan-motion"
    ]
    return Trial(seed, result.bound is not None, recorder.searches[first:], motions)


def _worker(args: argparse.Namespace) -> int:
    """One trial in this process (whichever planner package PYTHONPATH gives), as JSON."""
    trial = _trial(_recorder(), args.scene, parse_seeds(args.seeds)[0], args.planner, args.budget)
    out = {
        "seed": trial.seed,
        "solved": trial.solved,
        "searches": [[s.dims, s.checks, s.seconds, s.solved] for s in trial.searches],
        "motions": trial.motions,
    }
    print(json.dumps(out))
    return 0


def _fresh_process(tree: Path, args: argparse.Namespace, seed: int) -> Trial:
    """One trial in a fresh process with the planner package of ``tree``."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    cmd = [sys.executable, __file__, "--worker", "--scene", args.scene, "--seeds", str(seed)]
    cmd += ["--planner", args.planner, "--budget", str(args.budget)]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"the trial of seed {seed} in {tree} failed:\n{done.stderr}")
    data: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    searches = [Search(int(d), int(c), float(s), bool(ok)) for d, c, s, ok in data["searches"]]
    return Trial(int(data["seed"]), bool(data["solved"]), searches, list(data["motions"]))


def _pace(searches: list[Search]) -> tuple[float, float] | None:
    """Seconds per iteration: all seconds over all iterations, and the least-squares slope."""
    if len(searches) < 2:
        return None
    x = np.asarray([s.checks for s in searches], dtype=float)
    y = np.asarray([s.seconds for s in searches])
    slope, _ = np.polyfit(x, y, 1)
    return float(y.sum() / x.sum()), float(slope)


def _compare(args: argparse.Namespace, seeds: list[int]) -> int:
    before_tree = Path(args.before).resolve()
    if not (before_tree / "planner" / "__init__.py").is_file():
        print(f"{before_tree} holds no planner package", file=sys.stderr)
        return 2
    trees = {"before": before_tree, "after": HERE}
    trials: dict[str, dict[int, Trial]] = {"before": {}, "after": {}}
    for i, seed in enumerate(seeds):
        for name in ("before", "after") if i % 2 == 0 else ("after", "before"):
            trials[name][seed] = _fresh_process(trees[name], args, seed)
            trial = trials[name][seed]
            print(
                f"seed {seed}, {name}: {'solved' if trial.solved else 'unsolved'}, "
                f"{len(trial.searches)} searches, {len(trial.motions)} motion queries",
                file=sys.stderr,
            )
    print(f"{args.scene}, {args.planner}, seeds {args.seeds}; before: {before_tree}, after: {HERE}")
    print(
        "| space | searches (before / after) | iterations | before: ms per iteration "
        "(all / slope) | after: ms per iteration (all / slope) | after / before per seed: "
        "median (min - max) |"
    )
    print("|---|---|---|---|---|---|")
    for dims, label in ((3, "base (3)"), (7, "arm (7)")):
        rows = {
            name: [s for seed in seeds for s in trials[name][seed].searches if s.dims == dims]
            for name in trials
        }
        paces = {name: _pace(rows[name]) for name in rows}
        ratios = []
        for seed in seeds:
            b = [s for s in trials["before"][seed].searches if s.dims == dims]
            a = [s for s in trials["after"][seed].searches if s.dims == dims]
            if b and a:
                per_b = sum(s.seconds for s in b) / sum(s.checks for s in b)
                per_a = sum(s.seconds for s in a) / sum(s.checks for s in a)
                ratios.append(per_a / per_b)
        cells = []
        for name in ("before", "after"):
            pace = paces[name]
            cells.append("-" if pace is None else f"{pace[0] * 1e3:.2f} / {pace[1] * 1e3:.2f}")
        ratio = (
            f"{statistics.median(ratios):.3f} ({min(ratios):.3f} - {max(ratios):.3f})"
            if ratios
            else "-"
        )
        iterations = " / ".join(str(sum(s.checks for s in rows[n])) for n in ("before", "after"))
        print(
            f"| {label} | {len(rows['before'])} / {len(rows['after'])} | {iterations} "
            f"| {cells[0]} | {cells[1]} | {ratio} |"
        )
    same_searches = same_motions = 0
    for seed in seeds:
        b, a = trials["before"][seed], trials["after"][seed]
        key_b = [(s.dims, s.checks, s.solved) for s in b.searches]
        key_a = [(s.dims, s.checks, s.solved) for s in a.searches]
        same_searches += key_b == key_a
        same_motions += b.motions == a.motions
        if key_b != key_a or b.motions != a.motions:
            print(f"seed {seed}: the trees' searches or motions differ")
    print(
        f"\nsame searches (space, iterations, outcome, in order): {same_searches} of "
        f"{len(seeds)} trials; same motions (every plan-motion query's trajectory): "
        f"{same_motions} of {len(seeds)}"
    )
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--scene", default="kitchen-4")
    parser.add_argument("--seeds", default="3000-3003", help="range LO-HI or a list a,b,c")
    parser.add_argument("--planner", default="baseline", choices=PLANNERS)
    parser.add_argument("--budget", type=float, default=300.0)
    parser.add_argument("--limits", default="100,200,300,500,1000", help="iteration limits")
    parser.add_argument(
        "--before", default=None, help="a source tree to pair with this one (see above)"
    )
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    try:
        seeds, limits = parse_seeds(args.seeds), parse_seeds(args.limits)
    except ValueError:
        parser.error("--seeds and --limits take LO-HI or a,b,c (integers)")
    if args.worker:
        return _worker(args)
    if args.before is not None:
        return _compare(args, seeds)
    recorder = _recorder()
    for seed in seeds:
        trial = _trial(recorder, args.scene, seed, args.planner, args.budget)
        print(
            f"seed {seed}: {'solved' if trial.solved else 'unsolved'}, "
            f"{len(recorder.searches)} searches so far",
            file=sys.stderr,
        )
    base, arm = SamplerConfig().motion, SamplerConfig().arm_motion
    print(
        f"{args.scene}, {args.planner}, seeds {args.seeds}; limits: base {base.iterations} "
        f"iterations or {base.timeout_s:g} s, arm {arm.iterations} iterations or "
        f"{arm.timeout_s:g} s"
    )
    print(
        "| space | searches | found | iterations of a found path: p50 / p90 / p99 / max "
        "| iterations / s | stopped without a path | "
        + " | ".join(f"found cut at {n}" for n in limits)
        + " |"
    )
    print("|---" * (6 + len(limits)) + "|")
    for dims, name in ((3, "base (3)"), (7, "arm (7)")):
        rows = [s for s in recorder.searches if s.dims == dims]
        if not rows:
            continue
        found = np.asarray([s.checks for s in rows if s.solved])
        stopped = sum(not s.solved for s in rows)
        pct = (
            " / ".join(f"{v:.0f}" for v in np.percentile(found, [50, 90, 99])) + f" / {found.max()}"
            if len(found)
            else "-"
        )
        cut = " | ".join(f"{int((found > n).sum())}" for n in limits)
        overall = sum(s.checks for s in rows) / max(sum(s.seconds for s in rows), 1e-9)
        print(
            f"| {name} | {len(rows)} | {len(found)} | {pct} | {overall:.0f} | {stopped} | {cut} |"
        )
    print("\nseconds of a search against its iterations (least squares), and the iterations")
    print("one second buys at that pace:")
    for dims, name in ((3, "base (3)"), (7, "arm (7)")):
        rows = [s for s in recorder.searches if s.dims == dims]
        if len(rows) < 2:
            continue
        x = np.asarray([s.checks for s in rows], dtype=float)
        y = np.asarray([s.seconds for s in rows])
        slope, intercept = np.polyfit(x, y, 1)
        print(
            f"  {name}: {intercept * 1e3:.1f} ms + {slope * 1e3:.2f} ms per iteration; "
            f"1 s = {(1.0 - intercept) / slope:.0f} iterations"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
