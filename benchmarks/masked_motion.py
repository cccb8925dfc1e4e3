"""Analysis: how the motion model's R_M compares with the real execution seconds, with the
move's inputs bound and with its end configuration masked (as the learned search predicts a
move whose target IK has not been sampled yet).

    .venv/bin/python benchmarks/masked_motion.py --db k4-collect-v4.db --long 9
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from planner.domains import load_domain
from planner.domains.kitchen import MODEL as DEFAULT_MODEL
from planner.learning.model import CostModel
from planner.store import RunStore


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--db", required=True, help="a run store with plan-motion queries")
    parser.add_argument("--model", default=str(DEFAULT_MODEL))
    parser.add_argument("--long", type=float, default=9.0, help="seconds from which a move is long")
    args = parser.parse_args()
    try:
        model = CostModel.load(args.model, domain=load_domain("kitchen"))
    except (OSError, ValueError) as exc:
        print(f"cannot load model {args.model}: {exc}", file=sys.stderr)
        return 2
    with RunStore(args.db) as store:
        queries = [q for q in store.stream_queries(stream="plan-motion") if q.success]
    if not queries:
        print(f"{args.db}: no successful plan-motion queries", file=sys.stderr)
        return 1
    actual = np.array([q.execution_s for q in queries])
    bound = model.predict_queries("plan-motion", [(q.inputs, q.context) for q in queries]).r_m
    masked = model.predict_queries(
        "plan-motion", [([q.inputs[0], None], q.context) for q in queries]
    ).r_m
    print("| moves | n | actual s | predicted, bound s | predicted, end masked s |")
    print("|---|---|---|---|---|")
    for name, rows in (("all", actual >= 0), (f"over {args.long:g} s", actual > args.long)):
        print(
            f"| {name} | {rows.sum()} | {actual[rows].mean():.2f} | {bound[rows].mean():.2f} "
            f"| {masked[rows].mean():.2f} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
