"""Benchmark: what each of the kitchen's four real streams costs, and how that depends on inputs.

Three parts, all through the stream runtime (so every figure is a ``QueryResult``'s wall time):

1. Realistic queries: for each seed, the first ``--k`` skeletons of ``plan_abstract`` are bound
   stream by stream exactly as :func:`planner.search.binding.bind_sequentially` does (same
   contexts, ``--attempts`` tries per stream, ``--restarts`` restarts), recording every query
   with its inputs. One Markdown table per stream, then breakdowns by platform and grasp kind.
2. Placement on the stove with 0..3 other blocks already standing on it: the other blocks are
   put there by the placement stream first (not counted), then ``--sweep`` queries per count.
3. IK by platform (table, sink, stove) and grasp kind (top, side): ``--sweep`` queries per cell
   (picking: the block stands at a pose drawn on that platform, the other blocks on the table).

    .venv/bin/python benchmarks/kitchen_streams.py --scene kitchen-4 --seeds 0-9 --k 4 \
        --attempts 5 --restarts 2 --sweep 300 --out /tmp/kitchen_streams.json
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import random
import sys
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from _common import parse_seeds

from planner.abstract import AbstractConfig, AbstractPlan, plan_abstract
from planner.domains import LoadedDomain, problem_for_scene
from planner.domains.kitchen import GEOMETRY_KEY
from planner.domains.kitchen.geometry import BlockPose, KitchenGeometry
from planner.domains.kitchen.values import Grasp, Trajectory
from planner.pddl.structs import Atom, Problem
from planner.search.binding import stream_contexts
from planner.streams.adapters import StreamContext
from planner.streams.runtime import QueryResult, StreamRuntime

STREAMS = ("sample-grasp", "sample-placement", "inverse-kinematics", "plan-motion")
PLATFORMS = ("table", "sink", "stove")
GRASP_KINDS = ("top", "side")


@dataclass
class Record:
    """One stream query and what it was asked in."""

    part: str  # "bind", "stove-sweep" or "ik-sweep"
    stream: str
    success: bool
    wall_s: float
    cpu_s: float
    error: str | None
    tags: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def of(cls, part: str, result: QueryResult, **tags: Any) -> Record:
        if (
            result.outputs is not None
            and result.outputs
            and isinstance(result.outputs[0], Trajectory)
        ):
            tags["trajectory_s"] = result.outputs[0].seconds
        return cls(
            part, result.stream, result.success, result.wall_s, result.cpu_s, result.error, tags
        )


def progress(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def percentile(xs: list[float], q: float) -> float:
    """Linear-interpolation percentile (q in 0..100) of a non-empty list."""
    s = sorted(xs)
    pos = (len(s) - 1) * q / 100
    lo, hi = math.floor(pos), math.ceil(pos)
    return s[lo] + (s[hi] - s[lo]) * (pos - lo)


def pct(ok: int, n: int) -> str:
    """A success rate that never rounds a rare failure or success away."""
    if 0 < ok < n and not 0.5 <= 100 * ok / n <= 99.5:
        return f"{100 * ok / n:.1f}%"
    return f"{100 * ok / n:.0f}%"


def med_p90(xs: list[float]) -> tuple[str, str]:
    if not xs:
        return "-", "-"
    return f"{percentile(xs, 50):.3g}", f"{percentile(xs, 90):.3g}"


# --- part 1: realistic contexts ---------------------------------------------------------------


def pose_platforms(plan: AbstractPlan, problem: Problem) -> dict[str, str]:
    """Pose object -> the platform it is on: initial poses from ``supported`` facts, optimistic
    ones from the placement stream that produces them."""
    where = {a.args[1]: a.args[2] for a in problem.init if a.predicate == "supported"}
    for inst in plan.stream_plan:
        if inst.stream == "sample-placement":
            where[inst.outputs[0]] = inst.inputs[1]
    return where


def describe(
    stream: str,
    inputs: tuple[Any, ...],
    names: tuple[str, ...],
    state: frozenset[Atom],
    where: dict[str, str],
) -> dict[str, Any]:
    """The tags a learned model could see: platform, blocks on it, grasp kind, pick or place."""
    holding = any(a.predicate == "holding" for a in state)
    tags: dict[str, Any] = {"holding": holding}
    if stream == "sample-placement":
        plat = names[1]
        tags["platform"] = plat
        tags["blocks_on_platform"] = sum(
            1 for a in state if a.predicate == "on" and a.args[1] == plat
        )
    elif stream == "inverse-kinematics":
        tags["platform"] = where.get(names[1], "?")
        grasp = inputs[2]
        tags["grasp"] = grasp.kind if isinstance(grasp, Grasp) else "?"
        tags["action"] = "place" if holding else "pick"
    return tags


def bind_recording(
    plan: AbstractPlan,
    loaded: LoadedDomain,
    problem: Problem,
    runtime: StreamRuntime,
    *,
    attempts: int,
    restarts: int,
    out: list[Record],
    tags: dict[str, Any],
) -> bool:
    """``bind_sequentially``'s loop, keeping each query's inputs; True when the plan is bound."""
    contexts = stream_contexts(plan, loaded.domain, problem)
    where = pose_platforms(plan, problem)
    for restart in range(restarts):
        values: dict[str, Any] = {
            o.name: problem.values.get(o.name, o.name) for o in problem.objects
        }
        for inst, state in zip(plan.stream_plan, contexts, strict=True):
            inputs = tuple(values[name] for name in inst.inputs)
            context = StreamContext(state, values)
            info = describe(inst.stream, inputs, inst.inputs, state, where)
            for _ in range(attempts):
                result = runtime.query(
                    inst.stream, inputs, key=(restart, inst.stream, inst.inputs), context=context
                )
                out.append(Record.of("bind", result, restart=restart, **tags, **info))
                if result.outputs is not None:
                    values.update(zip(inst.outputs, result.outputs, strict=True))
                    break
            else:
                break
        else:
            return True
    return False


def realistic(
    scene: str, seeds: list[int], k: int, attempts: int, restarts: int, out: list[Record]
) -> list[dict[str, Any]]:
    binds = []
    for seed in seeds:
        loaded, problem = problem_for_scene(scene, seed=seed)
        config = AbstractConfig(k=k, diversity_ignore=loaded.spec.diversity_ignore)
        plans = plan_abstract(loaded.domain, loaded.streams, problem, config).plans
        runtime = loaded.runtime(problem, seed=seed)
        for i, plan in enumerate(plans):
            t = time.perf_counter()
            before = len(out)
            bound = bind_recording(
                plan,
                loaded,
                problem,
                runtime,
                attempts=attempts,
                restarts=restarts,
                out=out,
                tags={"seed": seed, "skeleton": i},
            )
            seconds = time.perf_counter() - t
            binds.append(
                {
                    "seed": seed,
                    "skeleton": i,
                    "bound": bound,
                    "queries": len(out) - before,
                    "seconds": seconds,
                }
            )
            progress(
                f"  bind seed {seed} skeleton {i}: {'bound' if bound else 'FAILED'}, "
                f"{len(out) - before} queries, {seconds:.1f} s"
            )
    return binds


# --- parts 2 and 3: controlled sweeps ---------------------------------------------------------


class Sweep:
    """A runtime of its own and helpers to build contexts by hand."""

    def __init__(self, scene: str, seed: int) -> None:
        self.loaded, self.problem = problem_for_scene(scene, seed=seed)
        self.runtime = self.loaded.runtime(self.problem, seed=seed)
        geometry = self.problem.values[GEOMETRY_KEY]
        assert isinstance(geometry, KitchenGeometry)
        self.geometry = geometry
        self.blocks = [b.name for b in geometry.blocks]
        self.rng = random.Random(seed)

    @staticmethod
    def context(poses: dict[str, BlockPose]) -> StreamContext:
        """A state where each block stands at its pose (object ``sp-<block>``)."""
        state = frozenset(Atom("at-pose", (b, f"sp-{b}")) for b in poses)
        return StreamContext(state, {f"sp-{b}": pose for b, pose in poses.items()})

    def table_poses(self, exclude: Iterable[str]) -> dict[str, BlockPose]:
        """Initial table poses of a fresh draw (the spawn distribution), minus ``exclude``."""
        poses = self.geometry.initial_poses(self.rng.randrange(1 << 30))
        skip = set(exclude)
        return {b: p for b, p in poses.items() if b not in skip}

    def place(self, block: str, plat: str, poses: dict[str, BlockPose]) -> BlockPose | None:
        """A placement of ``block`` on ``plat`` among ``poses`` (not recorded), or None."""
        for _ in range(50):
            result = self.runtime.query(
                "sample-placement", (block, plat), context=self.context(poses)
            )
            if result.outputs is not None:
                pose = result.outputs[0]
                assert isinstance(pose, BlockPose)
                return pose
        return None

    def grasp(self, block: str, kind: str) -> Grasp:
        while True:
            result = self.runtime.query("sample-grasp", (block,))
            assert result.outputs is not None
            grasp = result.outputs[0]
            if isinstance(grasp, Grasp) and grasp.kind == kind:
                return grasp


def stove_sweep(sweep: Sweep, n_queries: int, out: list[Record]) -> None:
    """Placement on the stove with 0..3 other blocks there (a fresh arrangement per query)."""
    stove = next(p.name for p in sweep.geometry.platforms if p.kind == "stove")
    for n in range(min(4, len(sweep.blocks))):
        t = time.perf_counter()
        done = 0
        while done < n_queries:
            target, *others = sweep.rng.sample(sweep.blocks, n + 1)
            poses = sweep.table_poses(exclude=[target, *others])
            for other in others:
                pose = sweep.place(other, stove, poses)
                if pose is None:
                    break
                poses[other] = pose
            else:
                result = sweep.runtime.query(
                    "sample-placement", (target, stove), context=sweep.context(poses)
                )
                out.append(Record.of("stove-sweep", result, platform=stove, blocks_on_platform=n))
                done += 1
        progress(f"  stove sweep, {n} on the stove: {time.perf_counter() - t:.1f} s")


def ik_sweep(sweep: Sweep, n_queries: int, out: list[Record]) -> None:
    """IK when picking a block from each platform, with each grasp kind."""
    for plat in PLATFORMS:
        for kind in GRASP_KINDS:
            t = time.perf_counter()
            done = 0
            while done < n_queries:
                block = sweep.rng.choice(sweep.blocks)
                poses = sweep.table_poses(exclude=[] if plat == "table" else [block])
                if plat != "table":
                    pose = sweep.place(block, plat, poses)
                    if pose is None:
                        continue
                    poses[block] = pose
                grasp = sweep.grasp(block, kind)
                result = sweep.runtime.query(
                    "inverse-kinematics",
                    (block, poses[block], grasp),
                    context=sweep.context(poses),
                )
                out.append(Record.of("ik-sweep", result, platform=plat, grasp=kind))
                done += 1
            progress(f"  IK sweep, {plat} / {kind}: {time.perf_counter() - t:.1f} s")


# --- tables -----------------------------------------------------------------------------------


def stream_table(records: list[Record]) -> list[str]:
    rows = [
        "| stream | queries | success | median s ok | p90 s ok | median s failed | p90 s failed "
        "| errors | median trajectory s |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for stream in STREAMS:
        rs = [r for r in records if r.stream == stream]
        if not rs:
            continue
        ok = [r.wall_s for r in rs if r.success]
        bad = [r.wall_s for r in rs if not r.success]
        traj = [r.tags["trajectory_s"] for r in rs if "trajectory_s" in r.tags]
        errors = sum(1 for r in rs if r.error)
        rows.append(
            f"| {stream} | {len(rs)} | {pct(len(ok), len(rs))} | {' | '.join(med_p90(ok))} | "
            f"{' | '.join(med_p90(bad))} | {errors} | "
            f"{f'{percentile(traj, 50):.2f}' if traj else '-'} |"
        )
    return rows


def group_table(
    records: list[Record], header: str, key: Callable[[Record], Any], keys: Iterable[Any]
) -> list[str]:
    rows = [
        f"| {header} | queries | success | median s ok | median s failed |",
        "|---|---|---|---|---|",
    ]
    for k in keys:
        rs = [r for r in records if key(r) == k]
        if not rs:
            continue
        ok = [r.wall_s for r in rs if r.success]
        bad = [r.wall_s for r in rs if not r.success]
        label = " / ".join(map(str, k)) if isinstance(k, tuple) else str(k)
        rows.append(
            f"| {label} | {len(rs)} | {pct(len(ok), len(rs))} | {med_p90(ok)[0]} | "
            f"{med_p90(bad)[0]} |"
        )
    return rows


def report(records: list[Record], binds: list[dict[str, Any]]) -> str:
    bind = [r for r in records if r.part == "bind"]
    place = [r for r in bind if r.stream == "sample-placement"]
    ik = [r for r in bind if r.stream == "inverse-kinematics"]
    motion = [r for r in bind if r.stream == "plan-motion"]
    stove = [r for r in records if r.part == "stove-sweep"]
    iks = [r for r in records if r.part == "ik-sweep"]
    bound = sum(1 for b in binds if b["bound"])
    lines = [
        f"Realistic queries ({len(binds)} skeletons bound in order, {bound} fully bound):",
        "",
        *stream_table(bind),
        "",
        "Realistic placements by platform and blocks already on it:",
        "",
        *group_table(
            place,
            "platform / blocks on it",
            lambda r: (r.tags["platform"], r.tags["blocks_on_platform"]),
            [(p, n) for p in PLATFORMS for n in range(5)],
        ),
        "",
        "Realistic IK by platform, grasp kind and pick / place:",
        "",
        *group_table(
            ik,
            "platform / grasp / action",
            lambda r: (r.tags["platform"], r.tags["grasp"], r.tags["action"]),
            [(p, g, a) for p in PLATFORMS for g in GRASP_KINDS for a in ("pick", "place")],
        ),
        "",
        "Realistic motions, carrying a block or not:",
        "",
        *group_table(
            motion,
            "holding",
            lambda r: "carrying" if r.tags["holding"] else "empty hand",
            ["empty hand", "carrying"],
        ),
        "",
        "Placement on the stove by blocks already on it (controlled):",
        "",
        *group_table(
            stove, "blocks on the stove", lambda r: r.tags["blocks_on_platform"], range(4)
        ),
        "",
        "IK (picking) by platform and grasp kind (controlled):",
        "",
        *group_table(
            iks,
            "platform / grasp",
            lambda r: (r.tags["platform"], r.tags["grasp"]),
            [(p, g) for p in PLATFORMS for g in GRASP_KINDS],
        ),
    ]
    errors = sorted({f"{r.stream}: {r.error}" for r in records if r.error})
    if errors:
        lines += ["", "Errors raised by samplers:", *(f"- {e}" for e in errors)]
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--scene", default="kitchen-4")
    parser.add_argument("--seeds", default="0-9", help="e.g. 0-9 or 0,2,5")
    parser.add_argument("--k", type=int, default=4, help="skeletons bound per seed")
    parser.add_argument("--attempts", type=int, default=5, help="tries per stream, as the binder")
    parser.add_argument("--restarts", type=int, default=2, help="restarts per skeleton")
    parser.add_argument("--sweep", type=int, default=300, help="queries per controlled cell")
    parser.add_argument("--out", default=None, help="write every query and the tables as JSON")
    args = parser.parse_args()
    seeds = parse_seeds(args.seeds)
    if not seeds or args.k < 1 or args.attempts < 1 or args.restarts < 1 or args.sweep < 1:
        parser.error("need at least one seed, and positive --k, --attempts, --restarts, --sweep")
    started = time.perf_counter()
    records: list[Record] = []
    progress(f"part 1: binding {args.k} skeletons for seeds {args.seeds} of {args.scene}")
    binds = realistic(args.scene, seeds, args.k, args.attempts, args.restarts, records)
    t1 = time.perf_counter()
    sweep = Sweep(args.scene, seed=1000 + seeds[0])
    progress("part 2: placement on the stove by blocks already there")
    stove_sweep(sweep, args.sweep, records)
    progress("part 3: IK by platform and grasp kind")
    ik_sweep(sweep, args.sweep, records)
    total = time.perf_counter() - started
    text = report(records, binds)
    print(
        f"scene {args.scene}, seeds {args.seeds}, k={args.k}, attempts={args.attempts}, "
        f"restarts={args.restarts}, sweep={args.sweep}; {platform.machine()}, "
        f"Python {platform.python_version()}; part 1 {t1 - started:.0f} s, "
        f"total {total:.0f} s\n"
    )
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            json.dump(
                {
                    "args": vars(args),
                    "seconds": {"realistic": t1 - started, "total": total},
                    "binds": binds,
                    "tables": text,
                    "queries": [r.__dict__ for r in records],
                },
                f,
                indent=1,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
