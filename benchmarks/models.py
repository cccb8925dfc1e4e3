"""Benchmark: two model files for the learned planner, paired with the baseline on the same seeds.

    .venv/bin/python benchmarks/models.py --models planner/learning/models/kitchen.pt,new.pt \\
        --scene kitchen-4 --seeds 1000-1039 --budget 300 --workers 2 --db models.db

Every seed runs the baseline and the learned planner with each model, in an order rotating
from seed to seed so that machine noise hits them alike (fresh process per trial, recorded
through planner.experiment). Prints, per arm, solved trials and mean planning / execution /
total seconds (timeouts counted at the budget); then the paired mean improvement of each
model over the baseline and of the second model over the first, with bootstrap 95%
intervals (planner.report.paired_improvement, seed 0).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
from _common import parse_seeds

from planner.experiment import Trial, TrialResult, run_trials, stderr_progress
from planner.report import paired_improvement
from planner.scene import SceneError, load_scene


def _times(r: TrialResult, budget: float) -> tuple[float, float, float]:
    """(planning, execution, total) seconds; a trial not solved counts at the budget."""
    if r.status != "solved":
        return budget, 0.0, budget
    planning, execution = r.planning_s or 0.0, r.execution_s or 0.0
    return planning, execution, planning + execution


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--models", required=True, help="two model files, comma-separated")
    parser.add_argument("--scene", default="kitchen-4")
    parser.add_argument("--seeds", default="1000-1039")
    parser.add_argument("--budget", type=float, default=300.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--db", default=None)
    args = parser.parse_args()
    models = args.models.split(",")
    if len(models) != 2:
        parser.error("--models takes two model files")
    if models[0] == models[1]:
        parser.error("--models: the two files are the same")
    for m in models:
        if not Path(m).is_file():
            parser.error(f"--models: no such file: {m}")
    try:
        seeds = parse_seeds(args.seeds)
    except ValueError:
        parser.error("--seeds takes LO-HI or a,b,c (integers)")
    if not seeds or args.workers < 1 or args.budget <= 0:
        parser.error("need seeds, a positive --budget and --workers >= 1")
    try:
        load_scene(args.scene)
    except SceneError as exc:
        parser.error(f"--scene: {exc}")
    arms: list[tuple[str, str | None]] = [("baseline", None)]
    arms += [(f"learned:{i + 1}", m) for i, m in enumerate(models)]
    db = args.db or str(Path(tempfile.mkdtemp()) / "models.db")
    trials: list[Trial] = []
    label: dict[tuple[str, str | None], str] = {}
    for k, s in enumerate(seeds):
        rotated = arms[k % len(arms) :] + arms[: k % len(arms)]
        for name, model in rotated:
            planner = "baseline" if model is None else "learned"
            trials.append(Trial(args.scene, s, planner, args.budget, model))
            label[(planner, model)] = name
    results = run_trials(trials, db, workers=args.workers, progress=stderr_progress)
    by = {(label[(r.trial.planner, r.trial.model)], r.trial.seed): r for r in results}

    print(f"{args.scene}, seeds {args.seeds}, budget {args.budget:g} s, db {db}")
    for i, m in enumerate(models):
        print(f"learned:{i + 1} = {m}")
    print("| arm | solved | planning s | execution s | total s |")
    print("|---|---|---|---|---|")
    for name, _ in arms:
        rows = [_times(by[(name, s)], args.budget) for s in seeds]
        solved = sum(by[(name, s)].status == "solved" for s in seeds)
        means = [float(np.mean([r[i] for r in rows])) for i in range(3)]
        print(
            f"| {name} | {solved}/{len(seeds)} | {means[0]:.1f} | {means[1]:.1f} | {means[2]:.1f} |"
        )

    def improvement(ours: str, ref: str, part: int) -> str:
        a = [_times(by[(ours, s)], args.budget)[part] for s in seeds]
        b = [_times(by[(ref, s)], args.budget)[part] for s in seeds]
        p = paired_improvement(a, b, np.random.default_rng(0))
        if p["mean"] is None:
            return "-"
        return f"{100 * p['mean']:.1f}% ({100 * p['low']:.1f} to {100 * p['high']:.1f})"  # type: ignore[operator]

    print("\n| paired mean improvement | planning | execution | total |")
    print("|---|---|---|---|")
    pairs = (("learned:1", "baseline"), ("learned:2", "baseline"), ("learned:2", "learned:1"))
    for ours, ref in pairs:
        cells = " | ".join(improvement(ours, ref, part) for part in range(3))
        print(f"| {ours} over {ref} | {cells} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
