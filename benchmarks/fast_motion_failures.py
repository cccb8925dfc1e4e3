"""Benchmark analysis: why did a kitchen benchmark's motion queries fail at once?

    .venv/bin/python benchmarks/fast_motion_failures.py 7c4148cf76a1 --db bench-k6-v5.db

Takes the benchmark's plan-motion queries that failed within ``--under`` seconds (no search
grown: the start or goal collides) and puts the world back as each query saw it, from its
stored inputs and context (blocks on their poses, the held block in the hand). The robot
then stands at the query's start configuration, at the approach if it has one, where every
motion away begins. Prints how many there are by what the hand holds and whether the start
collides with the motion planner's clearance and without it.
"""

from __future__ import annotations

import argparse
import json
import random
import sys
from collections import Counter

from sqlalchemy import text

from planner.domains import load_domain
from planner.domains.kitchen.geometry import BlockPose, geometry_from_scene
from planner.domains.kitchen.samplers import KitchenSamplers, SamplerConfig
from planner.domains.kitchen.values import Conf, Grasp
from planner.scene import load_scene
from planner.store import RunStore

decode = load_domain("kitchen").decode  # the kitchen's value types


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("bench_id")
    parser.add_argument("--db", required=True)
    parser.add_argument("--under", type=float, default=0.05, help="seconds: a fast failure")
    args = parser.parse_args()
    if args.under <= 0:
        parser.error("--under must be positive")
    with RunStore(args.db) as store:
        try:
            bench = store.get_bench(args.bench_id)
        except KeyError as exc:  # the message lists the known benchmarks
            print(exc.args[0], file=sys.stderr)
            return 2
        with store.engine.connect() as conn:
            rows = conn.execute(
                text(
                    "select q.inputs, q.context from stream_queries q join bench_trials t "
                    "on t.run_id = q.run_id where t.bench_id = :b and q.stream = 'plan-motion' "
                    "and q.success = 0 and q.wall_s < :under"
                ),
                {"b": args.bench_id, "under": args.under},
            ).fetchall()
    geometry = geometry_from_scene(load_scene(bench.config["scene"]))
    samplers = KitchenSamplers(geometry, random.Random(0))
    world, clearance = samplers.world, SamplerConfig().clearance
    counts: Counter[tuple[str, bool, bool]] = Counter()
    for inputs, context in rows:
        start = decode(json.loads(inputs)[0], "q1")
        ctx = json.loads(context)
        values = {k: decode(v, k) for k, v in ctx["values"].items()}
        poses = {f[1]: values[f[2]] for f in ctx["facts"] if f[0] == "at-pose"}
        held = [(f[1], values[f[2]]) for f in ctx["facts"] if f[0] == "holding"]
        if not isinstance(start, Conf) or not all(isinstance(p, BlockPose) for p in poses.values()):
            print("not a kitchen motion query; skipped", file=sys.stderr)
            continue
        world.hold(None)
        world.set_blocks(poses)
        if held and isinstance(held[0][1], Grasp):
            world.hold(held[0][0], held[0][1])
        world.set_conf(start, approach=start.approach_arm is not None)
        key = (
            "holding a block" if held else "hand empty",
            world.robot_collides(clearance=clearance),
            world.robot_collides(),
        )
        counts[key] += 1
    print(
        f"{bench.config['scene']}, bench {args.bench_id}: {len(rows)} motion queries failed "
        f"within {args.under:g} s"
    )
    print(f"| hand | start collides with {clearance * 100:g} cm clearance | without | queries |")
    print("| --- | --- | --- | --- |")
    for (hand, with_clearance, without), n in sorted(counts.items()):
        print(f"| {hand} | {with_clearance} | {without} | {n} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
