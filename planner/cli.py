"""The ``tamp`` command."""

from __future__ import annotations

import argparse
import json
import logging
import signal
import sys
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from planner.abstract import (
    DEFAULT_SOURCE,
    MAX_K,
    SKELETON_SOURCES,
    AbstractConfig,
    AbstractPlan,
    AbstractPlanningError,
    AbstractResult,
    PlanReplayError,
    plan_abstract,
    replay,
)
from planner.domains import (
    DomainLoadError,
    LoadedDomain,
    domain_infos,
    known_domains,
    load_domain,
    problem_for_scene,
    scene_domain,
    scene_refs,
)
from planner.pddl import PDDLError, Problem, StreamSet
from planner.pddl.check import check_files
from planner.planners import DEFAULT_PLANNER, PLANNERS, PRIORS, get_planner
from planner.plans import PlanFileError
from planner.scene import SceneError
from planner.streams import StreamBindingError

log = logging.getLogger("tamp")

# Errors a user can cause; they are reported in one line, without a traceback.
USER_ERRORS = (
    PDDLError,
    DomainLoadError,
    PlanFileError,
    SceneError,
    AbstractPlanningError,
    StreamBindingError,
    ValueError,
    FileNotFoundError,
)


def _k(text: str) -> int:
    try:
        k = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if not 1 <= k <= MAX_K:
        raise argparse.ArgumentTypeError(f"k must be between 1 and {MAX_K}, got {k}")
    return k


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if not 1 <= value <= 100_000:
        raise argparse.ArgumentTypeError(f"expected a number from 1 to 100000, got {value}")
    return value


def _planner(text: str) -> str:
    try:
        get_planner(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


PLANNER_HELP = (
    f"a planner ({', '.join(PLANNERS)}) or a variant such as learned:dead_ends=off (docs/search.md)"
)


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def _bound(text: str) -> int:
    """A bound on queries or iterations: a positive whole number."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive whole number, got {value}")
    return value


def _add_bounds(parser: argparse.ArgumentParser, per: str) -> None:
    """--max-queries and --max-iterations (RunConfig.max_queries, max_iterations)."""
    parser.add_argument(
        "--max-queries",
        type=_bound,
        metavar="N",
        help=f"stop {per} after N stream queries a sampler answered, whatever the seconds: the "
        "same point on any machine (default: no bound; --budget still applies)",
    )
    parser.add_argument(
        "--max-iterations",
        type=_bound,
        metavar="N",
        help=f"stop {per} after N search iterations (sequential: skeletons tried), whatever "
        "the seconds (default: no bound)",
    )


DOMAIN_HELP = (
    "the domain: an installed domain's name or the path of a domain folder "
    '(default: the scene file\'s "domain")'
)


STORE_HELP = "run store: a SQLite path or a URL, postgresql+psycopg://... (default: user data)"


def _store(text: str) -> Path | str:
    """A ``--db``: a SQLite path, or a SQLAlchemy URL kept as written (a Path would fold its
    ``//``)."""
    return text if "://" in text else Path(text)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="tamp", description="guided-tamp: task and motion planning that learns where to search"
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress to stderr")
    sub = parser.add_subparsers(dest="command", required=True)

    ab = sub.add_parser(
        "abstract",
        help="k abstract plans and their stream plans",
        description="Find k unique skeletons (action plan + stream plan) with a skeleton source: "
        "adaptive (greedy searches, cheapest first without proving it) or a top-k planner (the "
        "k cheapest).",
    )
    src = ab.add_mutually_exclusive_group(required=True)
    src.add_argument("--scene", help="scene name (see `tamp scenes`) or path to a scene .json")
    src.add_argument("--problem", help="path to a PDDL problem file (needs --domain)")
    ab.add_argument("--domain", help=DOMAIN_HELP)
    ab.add_argument("--k", type=_k, default=50, help="unique skeletons wanted (default 50)")
    ab.add_argument(
        "--planner",
        choices=SKELETON_SOURCES,
        default=DEFAULT_SOURCE,
        help=f"skeleton source (default {DEFAULT_SOURCE}; kstar and symk: the k cheapest)",
    )
    ab.add_argument(
        "--timeout", type=_positive, default=300.0, help="seconds per planner call (default 300)"
    )
    ab.add_argument("--show", type=int, default=0, metavar="N", help="print N plans in full")
    ab.add_argument("--json", action="store_true", help="machine-readable output")

    pl = sub.add_parser(
        "plan",
        help="plan a scene: skeletons, then bind their streams with the real samplers",
        description="Plan a scene end to end and report planning and execution seconds.",
    )
    pl.add_argument("--scene", required=True, help="scene name (see `tamp scenes`) or path")
    pl.add_argument("--domain", help=DOMAIN_HELP)
    pl.add_argument("--seed", type=int, default=0, help="scene randomisation and sampler seed")
    pl.add_argument("--planner", type=_planner, default=DEFAULT_PLANNER, help=PLANNER_HELP)
    pl.add_argument(
        "--k",
        type=_k,
        default=50,
        help="skeletons: a top-k source's k; adaptive gives at most this many at first and more "
        "on demand (default 50)",
    )
    pl.add_argument(
        "--skeletons",
        choices=SKELETON_SOURCES,
        default=DEFAULT_SOURCE,
        help=f"skeleton source (default {DEFAULT_SOURCE}: greedy, on demand, replanning on what "
        "failed; kstar, symk: the k cheapest at once)",
    )
    pl.add_argument("--budget", type=_positive, default=300.0, help="seconds (default 300)")
    _add_bounds(pl, "the run")
    pl.add_argument("--out", type=Path, help="write the bound plan here (JSON)")
    pl.add_argument("--json", action="store_true", help="machine-readable summary")
    pl.add_argument("--db", type=_store, help="record the run in this store (default: user data)")
    pl.add_argument("--no-record", action="store_true", help="do not record the run")

    pl.add_argument(
        "--model",
        help="model file for --planner learned (default: the domain's own; without one, "
        f"per-stream priors from the queries in --db; '{PRIORS}': those priors, always)",
    )
    pl.add_argument("--c-explore", type=float, help="learned: UCT exploration weight")
    pl.add_argument(
        "--order",
        choices=("auto", "plan", "model"),
        default="auto",
        help="stream order of the tree search: as the actions need them (plan), cheap doubtful "
        "tests first by the model (model); auto: model for learned, plan otherwise",
    )

    co = sub.add_parser(
        "collect",
        help="run many recorded trials (training data)",
        description="Run trials of one scene on a process pool; every stream query is stored.",
    )
    co.add_argument("--scene", required=True, help="scene name or path")
    co.add_argument("--domain", help=DOMAIN_HELP)
    co.add_argument("--planner", type=_planner, default=DEFAULT_PLANNER, help=PLANNER_HELP)
    co.add_argument("--trials", type=_count, default=100, help="number of seeds (default 100)")
    co.add_argument("--seed-start", type=int, default=0, help="first seed (default 0)")
    co.add_argument("--budget", type=_positive, default=300.0, help="seconds per trial")
    _add_bounds(co, "each trial")
    co.add_argument("--workers", type=_count, default=2, help="processes (default 2)")
    co.add_argument("--db", type=_store, required=True, help="store to record into")
    co.add_argument("--model", help="model file for --planner learned")

    be = sub.add_parser(
        "bench",
        help="paired trials of several planners on the same seeds (the paper's comparison)",
        description="Run paired trials (same seeds for every planner, interleaved), store every "
        "run, and resume an interrupted benchmark with --resume. Then: tamp report BENCH_ID.",
    )
    be.add_argument("--scene", help="scene name or path (required unless --resume)")
    be.add_argument("--domain", help=DOMAIN_HELP)
    be.add_argument(
        "--planners",
        default="baseline,learned",
        help="comma-separated planners or variants: baseline,paper,learned,learned:dead_ends=off",
    )
    be.add_argument("--trials", type=int, default=20, help="seeds (default 20)")
    be.add_argument("--seed-start", type=int, default=1000, help="first seed (default 1000)")
    be.add_argument("--budget", type=float, default=300.0, help="seconds per trial")
    _add_bounds(be, "each trial")
    be.add_argument("--workers", type=_count, default=2, help="trials at once (default 2)")
    be.add_argument(
        "--model",
        help="model file for the learned planner (default: the domain's own; "
        f"'{PRIORS}': per-stream priors from the benchmark's store, as with no model)",
    )
    be.add_argument(
        "--order",
        choices=("auto", "plan", "model"),
        default="auto",
        help="stream order of every planner (see tamp plan --order; default auto)",
    )
    be.add_argument("--db", type=_store, help=STORE_HELP)
    be.add_argument("--ray-address", help="run the trials as Ray tasks: ADDRESS, auto, or local")
    be.add_argument("--resume", metavar="BENCH_ID", help="run the missing trials of a benchmark")

    ho = sub.add_parser(
        "horizon",
        help="the horizon curve: planning and total time against the number of objects",
        description="One benchmark per scene (the planners paired on the same seeds), taken "
        "from --db when one with the same settings is there (resumed if it did not finish), "
        "then the curve of each planner's mean planning and total seconds against the number "
        "of objects the scene's goal names, as a figure (.html: plotly, .svg: plain) and a "
        "table. Rerun the command to go on after an interruption.",
    )
    ho.add_argument(
        "--scenes", required=True, help="comma-separated scenes of one domain: kitchen-2,kitchen-4"
    )
    ho.add_argument("--domain", help=DOMAIN_HELP)
    ho.add_argument(
        "--planners", default="baseline,paper,learned", help="as tamp bench (default: the three)"
    )
    ho.add_argument("--trials", type=int, default=20, help="seeds per scene (default 20)")
    ho.add_argument("--seed-start", type=int, default=1000, help="first seed (default 1000)")
    ho.add_argument("--budget", type=float, default=300.0, help="seconds per trial")
    _add_bounds(ho, "each trial")
    ho.add_argument("--workers", type=_count, default=2, help="trials at once (default 2)")
    ho.add_argument("--model", help="model file for the learned planner (default: the domain's)")
    ho.add_argument("--db", type=_store, help=STORE_HELP)
    ho.add_argument("--ray-address", help="run the trials as Ray tasks: ADDRESS, auto, or local")
    ho.add_argument("--out", type=Path, help="figure: FILE.html (plotly) or FILE.svg")
    ho.add_argument(
        "--no-run",
        action="store_true",
        help="run nothing: draw the benchmarks the store already has (finished seeds only)",
    )

    rp = sub.add_parser(
        "report",
        help="report of a benchmark: figures, table, paired improvement",
        description="Write an HTML report (plotly figures, tables) of a benchmark, or --json.",
    )
    rp.add_argument("bench_id", nargs="?", help="benchmark id (default: the latest)")
    rp.add_argument("--db", type=_store, help=STORE_HELP)
    rp.add_argument("--out", type=Path, help="HTML file (default: the dashboard's reports dir)")
    rp.add_argument("--json", action="store_true", help="print the summary as JSON")

    tr = sub.add_parser(
        "train",
        help="train per-stream cost models from recorded stream queries",
        description="Fit P_S, R_S, R_F, R_M per stream; prints validation AUC and errors.",
    )
    tr.add_argument("--db", type=_store, action="append", required=True, help="run store(s)")
    tr.add_argument(
        "--domain", help="train for this domain (name or folder; default: the one in the stores)"
    )
    tr.add_argument("--out", type=Path, required=True, help="model file to write")
    tr.add_argument("--seed", type=int, default=0)
    tr.add_argument("--epochs", type=_count, default=300)
    tr.add_argument("--json", action="store_true", help="machine-readable report")

    va = sub.add_parser("validate", help="replay a bound plan in simulation")
    va.add_argument("plan", type=Path, help="a plan file written by `tamp plan --out`")
    va.add_argument("--domain", help="the plan's domain, if not where the plan file says")

    re = sub.add_parser("render", help="render a scene to a PNG, headless")
    re.add_argument("--scene", required=True)
    re.add_argument("--domain", help=DOMAIN_HELP)
    re.add_argument("--seed", type=int, default=0)
    re.add_argument("--out", type=Path, default=Path("scene.png"))
    re.add_argument("--width", type=int, default=960)
    re.add_argument("--height", type=int, default=720)

    ck = sub.add_parser(
        "check",
        help="load PDDL(Stream) files and list every declaration inferred from a use",
        description="Load domain, stream and problem files as the planner would (files are "
        "told apart by their header; a folder stands for its .pddl files) and list every "
        "predicate or function declared by its use and every repeated declaration accepted "
        "(PDDLStream's leniency). Exit status 0 when every file loads, 1 when one does not.",
    )
    ck.add_argument("paths", nargs="+", help="PDDL files or folders (a domain folder)")
    ck.add_argument(
        "--strict", action="store_true", help="refuse undeclared names and repeated declarations"
    )
    ck.add_argument("--json", action="store_true", help="machine-readable output")

    sc = sub.add_parser("scenes", help="list the known scenes and their domains")
    sc.add_argument("--domain", action="append", help="also this domain folder's scenes")
    sub.add_parser("domains", help="list the installed domains (and why any does not load)")
    se = sub.add_parser(
        "serve",
        help="start the dashboard",
        description="Start the dashboard (FastAPI + the viser 3D view). Flags override TAMP_* "
        "environment variables (docs/dashboard.md).",
    )
    se.add_argument("--host", help="address to bind (default 127.0.0.1: this machine only)")
    se.add_argument(
        "--allow-remote",
        action="store_true",
        help="let a --host beyond this machine serve without a token (TAMP_TOKEN)",
    )
    se.add_argument("--port", type=int, help="port of the page and API (default 8000)")
    se.add_argument("--db", help="run store: SQLite path or SQLAlchemy URL (default: tamp plan's)")
    se.add_argument("--viewer-port", type=int, help="port of the 3D view (default 8080)")
    se.add_argument("--no-viewer", action="store_true", help="do not start the 3D view")
    se.add_argument("--max-running", type=int, help="runs planning at once (default 1)")
    se.add_argument("--max-queued", type=int, help="runs waiting for a slot (default 20)")
    se.add_argument("--models", type=Path, help="directory of model files offered by name")
    se.add_argument("--reports", type=Path, help="directory of benchmark reports (*.html)")
    se.add_argument(
        "--domain",
        action="append",
        metavar="PATH",
        help="a domain folder whose scenes the dashboard offers (repeatable)",
    )
    return parser


def _domain_ref(loaded: LoadedDomain, given: str | None) -> str | None:
    """What a run records of its domain: the folder of one loaded from a path (so any process
    finds it again), the name given, or None (the scene file says)."""
    return loaded.reference if loaded.reference is not None else given


def _plan_json(
    rank: int, plan: AbstractPlan, problem: Problem, domain: Any, streams: StreamSet | None = None
) -> dict[str, Any]:
    try:
        replay(plan, domain, problem, streams)
        valid, error = True, None
    except PlanReplayError as exc:
        valid, error = False, str(exc)
    return {
        "rank": rank,
        "cost": plan.cost,
        "length": len(plan.actions),
        "actions": [str(a) for a in plan.actions],
        "stream_plan": [
            {
                "stream": s.stream,
                "inputs": list(s.inputs),
                "outputs": list(s.outputs),
                "level": s.level,
                "certified": [str(a) for a in s.certified],
            }
            for s in plan.stream_plan
        ],
        "valid": valid,
        "error": error,
    }


def _summary(result: AbstractResult) -> dict[str, Any]:
    return {
        "backend": result.backend,
        "seconds": {k: round(v, 4) for k, v in result.seconds.items()},
        "rounds": result.rounds,
        "requested": result.requested,
        "returned": result.returned,
        "unique": result.unique,
        "exhausted": result.exhausted,
        "stop_reason": result.stop_reason,
        "stream_instances": result.instances,
        "distinct_multisets": result.distinct_multisets,
        "distinct_choices": result.distinct_choices,
        "diversity_ignore": list(result.diversity_ignore),
    }


def cmd_abstract(args: argparse.Namespace) -> int:
    if args.scene:
        loaded, problem = problem_for_scene(args.scene, domain=args.domain)
        name = args.scene
    else:
        if not args.domain:
            raise ValueError(
                f"--problem needs --domain ({', '.join(known_domains())}, or a domain folder)"
            )
        loaded = load_domain(args.domain)
        problem = loaded.problem_from_file(args.problem)
        name = args.problem
    config = AbstractConfig(
        k=args.k,
        backend=args.planner,
        timeout_s=args.timeout,
        diversity_ignore=loaded.spec.diversity_ignore,
    )
    result = plan_abstract(
        loaded.domain, loaded.streams, problem, config, progress=_progress_line()
    )
    plans = [
        _plan_json(i + 1, p, problem, loaded.domain, loaded.streams)
        for i, p in enumerate(result.plans)
    ]
    if sys.stderr.isatty():
        sys.stderr.write("\r\033[K")
    if args.json:
        out = {"problem": name, "domain": loaded.domain.name, "k": args.k, **_summary(result)}
        out["plans"] = plans
        print(json.dumps(out, indent=2))
    else:
        _print_text(name, args.k, result, plans, args.show)
    return 0 if all(p["valid"] for p in plans) else 1


def _progress_line() -> Callable[[str], None] | None:
    """A status line on stderr that overwrites itself, only on an interactive terminal."""
    if not sys.stderr.isatty():
        return None

    def show(message: str) -> None:
        sys.stderr.write(f"\r\033[K{message}")
        sys.stderr.flush()

    return show


def _print_text(
    name: str, k: int, result: AbstractResult, plans: list[dict[str, Any]], show: int
) -> None:
    s = result.seconds
    print(
        f"{name}: {len(result.plans)} of {k} skeletons from {result.backend} in {s['total']:.2f} s "
        f"(instantiate {s['instantiate']:.2f} s, ground {s['ground']:.2f} s, "
        f"search {s['topk']:.2f} s, stream plans {s['recover']:.2f} s)"
    )
    calls = "search(es)" if result.backend == "adaptive" else "top-k call(s)"
    print(
        f"  {result.instances} optimistic stream instances; {result.rounds} {calls}, "
        f"{result.unique} unique skeletons"
        + {"enough": "", "exhausted": "; the source has no more"}[result.stop_reason]
    )
    ignored = ", ".join(result.diversity_ignore)
    print(
        f"  {result.distinct_multisets} distinct action multisets"
        + (f", {result.distinct_choices} ignoring {ignored}" if ignored else "")
    )
    print(f"  {'#':>3} {'len':>4} {'cost':>5} {'streams':>7}  valid  stream plan")
    for p in plans:
        counts = Counter(st["stream"] for st in p["stream_plan"])
        mix = ", ".join(f"{n} x{c}" for n, c in counts.items())
        print(
            f"  {p['rank']:>3} {p['length']:>4} {p['cost']:>5g} {len(p['stream_plan']):>7}  "
            f"{'yes' if p['valid'] else 'NO':>5}  {mix}"
        )
    for p in plans[:show]:
        print(f"\nplan {p['rank']} (cost {p['cost']:g}):")
        for st in p["stream_plan"]:
            outs = " -> " + " ".join(st["outputs"]) if st["outputs"] else ""
            print(f"  stream {st['stream']}({' '.join(st['inputs'])}){outs}")
        for a in p["actions"]:
            print(f"  {a}")
        if not p["valid"]:
            print(f"  INVALID: {p['error']}")


def cmd_plan(args: argparse.Namespace) -> int:
    from planner.api import solve
    from planner.runs import preload_libraries, record_run, resolve_run
    from planner.store import RunStore, default_db_path

    # A bad scene or domain fails before anything is recorded.
    loaded, _ = problem_for_scene(args.scene, seed=args.seed, domain=args.domain)
    db = args.db or default_db_path()
    config = resolve_run(
        db,
        scene=args.scene,
        seed=args.seed,
        planner=args.planner,
        k=args.k,
        budget_s=args.budget,
        model=args.model,
        c_explore=args.c_explore,
        order=args.order,
        domain=_domain_ref(loaded, args.domain),
        skeletons=args.skeletons,
        max_queries=args.max_queries,
        max_iterations=args.max_iterations,
    )
    preload_libraries(config)
    progress = _progress_line()
    if args.no_record:
        out = solve(config, progress=progress)
        result = out.result
        valid, message = out.check()
        plan_data = out.plan_file()
    else:
        store = RunStore(db)
        run_id = store.create_run(args.scene, args.seed, args.planner, asdict(config))
        recorded = record_run(config, store, run_id, progress=progress)
        store.close()
        result, valid, message, plan_data = (
            recorded.result,
            recorded.valid,
            recorded.message,
            recorded.plan,
        )
    if sys.stderr.isatty():
        sys.stderr.write("\r\033[K")
    if plan_data is not None and args.out is not None:
        args.out.write_text(json.dumps(plan_data, indent=1) + "\n", encoding="utf-8")
    counts = result.query_counts()
    streams = sorted({s for s, _ in counts})
    summary = {
        "run_id": result.run_id,
        "scene": args.scene,
        "domain": loaded.name,
        "seed": args.seed,
        "planner": args.planner,
        "status": result.status,
        "valid": valid,
        "message": message,
        "planning_s": round(result.planning_s, 3),
        "topk_s": round(result.topk_s, 3),  # the skeleton source's seconds, every batch
        "skeleton_s": round(result.topk_s, 3),
        "oracle_s": None if result.oracle_s is None else round(result.oracle_s, 3),
        "execution_s": None if result.execution_s is None else round(result.execution_s, 3),
        "cost": result.bound.cost if result.bound is not None else None,
        "search_cpu_s": None if result.search_cpu_s is None else round(result.search_cpu_s, 3),
        "nodes": result.nodes,
        "queries": {s: {"ok": counts[(s, True)], "failed": counts[(s, False)]} for s in streams},
        "reused": result.reused,
        "plan_file": str(args.out) if args.out and plan_data else None,
        "db": None if args.no_record else str(db),
    }
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(f"{args.scene} seed {args.seed} ({args.planner}): {result.status}; {message}")
        line = f"  planning {result.planning_s:.2f} s (skeletons {result.topk_s:.2f} s"
        if result.oracle_s is not None:
            line += f", oracle {result.oracle_s:.2f} s"
        line += ")"
        if result.execution_s is not None:
            line += f", execution {result.execution_s:.2f} s"
        if result.bound is not None and result.bound.cost is not None:
            line += f", plan cost {result.bound.cost:g}"
        print(line)
        print(
            f"  tree nodes: {result.nodes}, queries: {len(result.queries)}"
            + (f" (and {result.reused} reused)" if result.reused else "")
            + (
                f"; the search's own CPU {result.search_cpu_s:.2f} s"
                if result.search_cpu_s is not None
                else ""
            )
        )
        for s in streams:
            print(f"  {s:20} {counts[(s, True)]:5} ok {counts[(s, False)]:5} failed")
        if summary["plan_file"]:
            print(f"  plan written to {args.out}")
        if summary["db"]:
            print(f"  run {result.run_id} recorded in {summary['db']}")
    return 0 if result.solved and valid else 1


def cmd_collect(args: argparse.Namespace) -> int:
    from planner.experiment import Trial, run_trials, stderr_progress
    from planner.runs import RunConfig

    # A bad scene fails before any trial starts.
    loaded, _ = problem_for_scene(args.scene, domain=args.domain)
    domain = _domain_ref(loaded, args.domain)
    RunConfig(
        scene=args.scene,
        planner=args.planner,
        budget_s=args.budget,
        model=args.model,
        max_queries=args.max_queries,
        max_iterations=args.max_iterations,
    )
    trials = [
        Trial(
            args.scene,
            seed,
            args.planner,
            args.budget,
            args.model,
            domain=domain,
            max_queries=args.max_queries,
            max_iterations=args.max_iterations,
        )
        for seed in range(args.seed_start, args.seed_start + args.trials)
    ]
    results = run_trials(trials, args.db, workers=args.workers, progress=stderr_progress)
    if sys.stderr.isatty():
        sys.stderr.write("\n")
    solved = [r for r in results if r.status == "solved"]
    failed = [r for r in results if r.status == "failed"]
    queries = sum(r.queries for r in results)
    print(
        f"{args.scene} ({args.planner}): {len(solved)}/{len(results)} solved, "
        f"{len(failed)} failed, {queries} stream queries recorded in {args.db}"
    )
    for r in failed:
        print(f"  seed {r.trial.seed}: {r.error}")
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from planner.bench import make_config, run_bench
    from planner.experiment import stderr_progress
    from planner.report import summarize, table_markdown
    from planner.store import default_db_path

    db = args.db or default_db_path()
    config = None
    if args.resume is None:
        if not args.scene:
            raise ValueError("--scene is required (or --resume BENCH_ID)")
        loaded, _ = problem_for_scene(args.scene, domain=args.domain)
        config = make_config(
            args.scene,
            args.planners.split(","),
            trials=args.trials,
            seed_start=args.seed_start,
            budget_s=args.budget,
            model=args.model,
            order=args.order,
            domain=_domain_ref(loaded, args.domain),
            max_queries=args.max_queries,
            max_iterations=args.max_iterations,
        )
    bench_id, results = run_bench(
        db,
        config,
        resume=args.resume,
        workers=args.workers,
        ray_address=args.ray_address,
        progress=stderr_progress,
    )
    if sys.stderr.isatty():
        sys.stderr.write("\n")
    crashed = [r for r in results if r.error]
    for r in crashed:
        print(f"  {r.trial.planner} seed {r.trial.seed} failed: {r.error}")
    print(table_markdown(summarize(db, bench_id)))
    print(f"benchmark {bench_id} in {db}; report: tamp report {bench_id} --db {db}")
    return 0


def cmd_horizon(args: argparse.Namespace) -> int:
    from planner.bench import make_config
    from planner.experiment import stderr_progress
    from planner.horizon import (
        figure_title,
        find_bench,
        points,
        run_horizon,
        table_markdown,
        write,
    )
    from planner.store import default_db_path

    db = args.db or default_db_path()
    scenes = [s.strip() for s in args.scenes.split(",") if s.strip()]
    planners = args.planners.split(",")
    settings: dict[str, Any] = {
        "trials": args.trials,
        "seed_start": args.seed_start,
        "budget_s": args.budget,
        "model": args.model,
        "domain": args.domain,
        "max_queries": args.max_queries,
        "max_iterations": args.max_iterations,
    }
    if args.no_run:
        ids = []
        for scene in scenes:
            found = find_bench(db, make_config(scene, planners, **settings))
            if found is None:
                print(f"  {scene}: no benchmark with these settings in {db}", file=sys.stderr)
            else:
                ids.append(found[0])
    else:
        ids = run_horizon(
            db,
            scenes,
            planners,
            **settings,
            workers=args.workers,
            ray_address=args.ray_address,
            progress=stderr_progress,
        )
        if sys.stderr.isatty():
            sys.stderr.write("\n")
    pts = points(db, ids)
    if not pts:
        raise ValueError("no benchmark to draw: run without --no-run first")
    print(table_markdown(pts))
    if args.out:
        for path in write(pts, args.out, title=figure_title(pts)):
            print(f"wrote {path}")
    print(f"benchmarks {', '.join(ids)} in {db}")
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from planner.report import render_html, summarize, table_markdown
    from planner.store import RunStore, default_db_path

    db = args.db or default_db_path()
    if "://" not in str(db) and not Path(db).is_file():  # a URL names a database server
        raise ValueError(f"no run store at {db}")
    bench_id = args.bench_id
    if bench_id is None:
        with RunStore(db) as store:
            benches = store.list_benches()
        if not benches:
            raise ValueError(f"no benchmarks in {db}; run tamp bench first")
        bench_id = benches[0].id
    try:
        summary = summarize(db, bench_id)
    except KeyError as exc:  # the message lists the known benchmarks
        raise ValueError(exc.args[0]) from exc
    if args.json:
        print(json.dumps(summary, indent=2))
        return 0
    out = args.out or default_db_path().parent / "reports" / f"bench-{bench_id}.html"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(render_html(summary), encoding="utf-8")
    print(table_markdown(summary))
    print(f"report written to {out}")
    return 0


def cmd_train(args: argparse.Namespace) -> int:
    from planner.learning.train import format_report, load_records, records_domain, train

    loaded = load_domain(args.domain) if args.domain else None
    records = load_records(args.db, domain=None if loaded is None else loaded.name)
    if not records:
        where = ", ".join(map(str, args.db))
        if loaded is not None:
            raise ValueError(f"no stream queries of domain {loaded.name!r} in {where}")
        raise ValueError(f"no stream queries in {where}")
    if loaded is None:
        try:
            loaded = records_domain(records)
        except ValueError as exc:
            raise ValueError(f"{exc} with --domain") from exc
    model, report = train(records, domain=loaded, seed=args.seed, epochs=args.epochs)
    model.save(args.out)
    if args.json:
        print(json.dumps(report.to_dict(), indent=2))
    else:
        print(f"domain {loaded.name}: {len(records)} queries")
        print(format_report(report))
        print(f"model written to {args.out}")
    return 0


def cmd_validate(args: argparse.Namespace) -> int:
    from planner.plans import read_plan, validate

    plan = read_plan(args.plan)
    domain = args.domain or plan.domain_path or plan.domain
    loaded, problem = problem_for_scene(plan.scene, seed=plan.seed, domain=domain)
    if loaded.name != plan.domain:
        raise PlanFileError(
            f"{args.plan}: the plan is for domain {plan.domain!r}, not {loaded.name!r}"
        )
    values = {**{o.name: o.name for o in problem.objects}, **problem.values}
    values.update(plan.decoded_values(loaded))
    runtime = loaded.runtime(problem, seed=plan.seed) if loaded.spec.bindings else None
    report = validate(loaded, problem, plan.actions, values, streams=plan.streams, runtime=runtime)
    if report.ok:
        seconds = f", {report.execution_s:.2f} s" if report.execution_s is not None else ""
        print(f"{args.plan}: {report.message} ({len(plan.actions)} actions{seconds})")
        return 0
    print(f"{args.plan}: INVALID: {report.message}")
    return 1


def cmd_render(args: argparse.Namespace) -> int:
    from planner.sim.render import render_scene

    loaded, problem = problem_for_scene(args.scene, seed=args.seed, domain=args.domain)
    if loaded.spec.view is None:
        raise ValueError(
            f"domain {loaded.name!r} has no scene description (DomainSpec.view): nothing to render"
        )
    info = render_scene(
        loaded.spec.view.scene(problem), out=args.out, width=args.width, height=args.height
    )
    print(f"wrote {info.path}")
    return 0


def cmd_scenes(args: argparse.Namespace) -> int:
    extra = [load_domain(d) for d in args.domain or ()]
    refs = scene_refs(extra)
    width = max((len(r.name) for r in refs), default=5)
    for ref in refs:
        try:
            domain = scene_domain(ref).name
        except (DomainLoadError, SceneError) as exc:
            domain = f"? ({exc})"
        print(f"{ref.name:<{width}}  {domain:<12}  {ref.path}")
    return 0


def cmd_check(args: argparse.Namespace) -> int:
    checks = check_files(args.paths, strict=args.strict)
    if args.json:
        print(json.dumps([c.to_json() for c in checks], indent=2))
        return 0 if all(c.ok for c in checks) else 1
    for c in checks:
        if not c.ok:
            print(f"{c.path}: does not load: {c.error}")
            continue
        inferred = f" ({len(c.inferred)} inferred)" if c.inferred else ""
        print(f"{c.path}: {c.summary}{inferred}")
        for i in c.inferred:
            print(f"  {i.place}: warning: {i.message}")
    loaded = sum(c.ok for c in checks)
    total = sum(len(c.inferred) for c in checks)
    print(f"{loaded} of {len(checks)} files load; {total} declarations inferred", end="")
    print(" (declare them to load with --strict)" if total else "")
    return 0 if loaded == len(checks) else 1


def cmd_domains(_: argparse.Namespace) -> int:
    for info in domain_infos():
        state = info.directory if info.error is None else f"NOT LOADED: {info.error}"
        print(f"{info.name:<12}  {info.source}")
        print(f"{'':<12}  {state}")
    return 0


def cmd_serve(args: argparse.Namespace) -> int:
    from pydantic import ValidationError

    from app.main import serve
    from app.settings import Settings

    given = {
        "host": args.host,
        "port": args.port,
        "database_url": args.db,
        "viewer_port": args.viewer_port,
        "viewer": False if args.no_viewer else None,
        "max_running": args.max_running,
        "max_queued": args.max_queued,
        "model_dir": args.models,
        "reports_dir": args.reports,
        "extra_domains": args.domain,
        "allow_remote": True if args.allow_remote else None,
    }
    try:
        settings = Settings(**{k: v for k, v in given.items() if v is not None})
    except ValidationError as exc:
        problems = "; ".join(f"{'.'.join(map(str, e['loc']))}: {e['msg']}" for e in exc.errors())
        raise ValueError(f"bad dashboard setting: {problems}") from exc
    serve(settings)
    return 0


COMMANDS = {
    "abstract": cmd_abstract,
    "plan": cmd_plan,
    "collect": cmd_collect,
    "train": cmd_train,
    "bench": cmd_bench,
    "report": cmd_report,
    "validate": cmd_validate,
    "render": cmd_render,
    "horizon": cmd_horizon,
    "scenes": cmd_scenes,
    "domains": cmd_domains,
    "check": cmd_check,
    "serve": cmd_serve,
}


def _model_errors() -> tuple[type[Exception], ...]:
    """Model-file errors, without importing torch for commands that do not need it."""
    if "planner.learning.model" not in sys.modules:
        return ()
    from planner.learning.model import ModelError

    return (ModelError,)


LONG_COMMANDS = ("plan", "collect", "bench", "horizon", "train")


def _interrupt_on_term() -> None:
    """SIGTERM (``kill``, a job scheduler) stops a long command the way Ctrl-C does: the run or
    benchmark is finished as cancelled / interrupted with what it has, trial processes are
    stopped, and ``--resume`` picks up. A command started with ``&`` from a script ignores
    Ctrl-C, so this is the way to stop it cleanly."""

    def stop(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, stop)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    if args.command in LONG_COMMANDS:
        _interrupt_on_term()
    try:
        return COMMANDS[args.command](args)
    except _model_errors() as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except USER_ERRORS as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except NotImplementedError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into `head` and the like
        return 0
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
