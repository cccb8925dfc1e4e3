"""Analysis: how well the placement model foresees a crowded platform, by how many blocks are
already on it, next to the room-left feature on its own (stores recorded before queries carried
their scene's geometry get it from the run's scene, as training does).

    .venv/bin/python benchmarks/stove_room.py --db k4-collect-v4.db --platform stove

By default only the validation trials of ``tamp train --seed 0`` (its 20% split by trial) are
counted; ``--all`` counts the training trials too.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from planner.domains import load_domain
from planner.domains.kitchen import MODEL as DEFAULT_MODEL
from planner.domains.kitchen.features import room_left
from planner.learning.model import CostModel
from planner.learning.train import auc, load_records, split_runs


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--db", required=True, help="a run store with sample-placement queries")
    parser.add_argument("--model", default=str(DEFAULT_MODEL))
    parser.add_argument("--platform", default="stove")
    parser.add_argument("--split-seed", type=int, default=0, help="the seed the model trained with")
    parser.add_argument("--all", action="store_true", help="count the training trials too")
    args = parser.parse_args()
    try:
        model = CostModel.load(args.model, domain=load_domain("kitchen"))
        records = load_records([args.db])
    except (OSError, ValueError) as exc:
        print(f"cannot load: {exc}", file=sys.stderr)
        return 2
    _, val = split_runs((q.run_id for q in records), val_fraction=0.2, seed=args.split_seed)
    keep = set(val)
    queries = [
        q
        for q in records
        if q.stream == "sample-placement"
        and q.inputs[1] == args.platform
        and (args.all or q.run_id in keep)
    ]
    if not queries:
        print(f"{args.db}: no placements on {args.platform}", file=sys.stderr)
        return 1
    p_s = model.predict_queries("sample-placement", [(q.inputs, q.context) for q in queries]).p_s
    room = np.array([room_left(q.inputs[0], q.inputs[1], q.context)[1] for q in queries])
    ok = np.array([q.success for q in queries])
    on = np.array(
        [
            sum(1 for f in q.context.get("facts", []) if f[0] == "on" and f[2] == args.platform)
            for q in queries
        ]
    )

    def fmt(x: float | None) -> str:
        return "-" if x is None else f"{x:.2f}"

    print(
        f"| blocks already on the {args.platform} | queries | succeeded | mean P_S "
        "| AUC of P_S | log loss of P_S | AUC of room alone |"
    )
    print("|---|---|---|---|---|---|---|")
    for n in sorted(set(on.tolist())):
        rows = on == n
        y, p = ok[rows], np.clip(p_s[rows], 1e-6, 1 - 1e-6)
        loss = float(-np.mean(np.where(y, np.log(p), np.log(1 - p))))
        print(
            f"| {n} | {rows.sum()} | {y.mean():.0%} | {p.mean():.2f} | {fmt(auc(y, p))} "
            f"| {loss:.3f} | {fmt(auc(y, room[rows]))} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
