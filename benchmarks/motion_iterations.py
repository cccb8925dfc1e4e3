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
"""

from __future__ import annotations

import argparse
import logging
import sys
from dataclasses import dataclass

import numpy as np
from base_choice import _parse_seeds

from planner.domains.kitchen.samplers import SamplerConfig
from planner.runs import PLANNERS, RunConfig, run


@dataclass(frozen=True)
class Search:
    dims: int
    checks: int
    seconds: float
    solved: bool


class _Recorder(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.searches: list[Search] = []

    def emit(self, record: logging.LogRecord) -> None:
        if "termination checks" in record.msg and isinstance(record.args, tuple):
            _, dims, checks, seconds, solved = record.args
            self.searches.append(Search(int(dims), int(checks), float(seconds), bool(solved)))


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--scene", default="kitchen-4")
    parser.add_argument("--seeds", default="3000-3003", help="range LO-HI or a list a,b,c")
    parser.add_argument("--planner", default="baseline", choices=PLANNERS)
    parser.add_argument("--budget", type=float, default=300.0)
    parser.add_argument("--limits", default="100,200,300,500,1000", help="iteration limits")
    args = parser.parse_args()
    try:
        seeds, limits = _parse_seeds(args.seeds), _parse_seeds(args.limits)
    except ValueError:
        parser.error("--seeds and --limits take LO-HI or a,b,c (integers)")
    recorder = _Recorder()
    motion = logging.getLogger("planner.sim.motion")
    motion.setLevel(logging.DEBUG)
    motion.addHandler(recorder)
    for seed in seeds:
        result, _, _ = run(
            RunConfig(scene=args.scene, seed=seed, planner=args.planner, budget_s=args.budget)
        )
        print(
            f"seed {seed}: {'solved' if result.bound else 'unsolved'}, "
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
