"""Benchmarks: paired trials of several planners on the same seeds, stored and resumable.

``tamp bench`` checks everything before the first trial (scene, planners, budget, trial count,
that the model fits the scene's domain and never saw the benchmark's seeds), records the
benchmark, then runs its trials interleaved (per seed, the planners one after the other, their
order alternating between seeds) so that machine noise hits every planner alike. Each finished
trial is recorded at once, so ``--resume BENCH_ID`` runs only what is missing.
"""

from __future__ import annotations

import hashlib
import logging
import subprocess
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from planner import __version__
from planner.api import MAX_BUDGET_S
from planner.domains import LoadedDomain, problem_for_scene
from planner.experiment import (
    BENCH_KEY,
    StoreUnreachableError,
    Trial,
    TrialResult,
    check_store_reachable,
    run_trials,
)
from planner.planners import PRIORS, get_planner
from planner.runs import ORDERS, PLANNERS, RunConfig
from planner.search.bounds import check_bound
from planner.status import CRASHED
from planner.store import BenchTrialRecord, RunStore

log = logging.getLogger(__name__)

MAX_TRIALS = 10_000  # seeds per benchmark


class BenchError(ValueError):
    """A benchmark that cannot start; the message says which setting is wrong."""


@dataclass(frozen=True)
class BenchConfig:
    scene: str
    planners: tuple[str, ...]
    seeds: tuple[int, ...]
    budget_s: float
    model: str | None = None  # model file of the learned planner (default: the domain's own)
    order: str = "auto"  # stream order of every planner (RunConfig.order)
    domain: str | None = None  # the domain's name or folder (RunConfig.domain)
    # Each trial's bounds besides its seconds (RunConfig.max_queries, max_iterations)
    max_queries: int | None = None
    max_iterations: int | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "scene": self.scene,
            "planners": list(self.planners),
            "seeds": list(self.seeds),
            "budget_s": self.budget_s,
            "model": self.model,
            "order": self.order,
            "domain": self.domain,
            "max_queries": self.max_queries,
            "max_iterations": self.max_iterations,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> BenchConfig:
        return cls(
            scene=str(data["scene"]),
            planners=tuple(data["planners"]),
            seeds=tuple(int(s) for s in data["seeds"]),
            budget_s=float(data["budget_s"]),
            model=data.get("model"),
            order=str(data.get("order", "auto")),  # benchmarks before --order: auto
            domain=data.get("domain"),
            # benchmarks before --max-queries and --max-iterations: seconds only
            max_queries=_optional_int(data.get("max_queries")),
            max_iterations=_optional_int(data.get("max_iterations")),
        )

    def uses_model(self, planner: str) -> bool:
        """Does ``planner`` load the model in this benchmark (to search, or to order)?"""
        spec = get_planner(planner)
        return spec.uses_model or (self.order == "model" and spec.kind.name != "sequential")


def _optional_int(value: Any) -> int | None:
    return None if value is None else int(value)


def make_config(
    scene: str,
    planners: Sequence[str],
    *,
    trials: int,
    seed_start: int,
    budget_s: float,
    model: str | None = None,
    order: str = "auto",
    domain: str | None = None,
    max_queries: int | None = None,
    max_iterations: int | None = None,
) -> BenchConfig:
    """A checked configuration; :class:`BenchError` names what is wrong. A learned planner with
    no ``model`` takes the domain's own model, or runs on per-stream priors when it has none.
    ``max_queries`` and ``max_iterations`` bound each trial besides its seconds
    (:mod:`planner.search.bounds`)."""
    names = tuple(p.strip() for p in planners if p.strip())
    unknown = []
    for p in names:
        try:
            get_planner(p)
        except ValueError as exc:
            unknown.append(f"{p!r} ({exc})")
    if not names or unknown:
        raise BenchError(
            f"unknown planner(s) {', '.join(unknown) or '(none given)'} "
            f"(known: {', '.join(PLANNERS)}, or variants such as learned:dead_ends=off)"
        )
    for p in names:
        own_model = get_planner(p).model
        if own_model not in (None, PRIORS) and not Path(str(own_model)).is_file():
            raise BenchError(f"planner {p!r}: no model file {own_model}")
    if len(set(names)) != len(names):
        raise BenchError(f"a planner is listed twice: {', '.join(names)}")
    if not 1 <= trials <= MAX_TRIALS:
        raise BenchError(f"--trials must be between 1 and {MAX_TRIALS}, got {trials}")
    if seed_start < 0:
        raise BenchError(f"--seed-start must be >= 0, got {seed_start}")
    if not 0 < budget_s <= MAX_BUDGET_S:
        raise BenchError(f"--budget must be in (0, {MAX_BUDGET_S:.0f}] seconds, got {budget_s}")
    if order not in ORDERS:
        raise BenchError(f"--order must be one of {', '.join(ORDERS)}, got {order!r}")
    for flag, bound in (("--max-queries", max_queries), ("--max-iterations", max_iterations)):
        try:
            check_bound(flag, bound)
        except ValueError as exc:
            raise BenchError(str(exc)) from None
    needs_model = any(get_planner(p).uses_model for p in names) or order == "model"
    if model is not None and not needs_model:
        raise BenchError(
            "--model is only used by the learned planner or --order model, neither is asked"
        )
    if needs_model and model is None:
        own = _scene_domain(scene, domain).spec.model
        model = None if own is None else str(own)
    return BenchConfig(
        scene,
        names,
        tuple(range(seed_start, seed_start + trials)),
        float(budget_s),
        model,
        order,
        domain,
        max_queries,
        max_iterations,
    )


def _scene_domain(scene: str, domain: str | None) -> LoadedDomain:
    return problem_for_scene(scene, domain=domain)[0]


def check(config: BenchConfig) -> dict[str, Any]:
    """Everything that can fail before a trial starts; returns what the report shows about the
    model (its file and the seeds that trained it)."""
    loaded = _scene_domain(config.scene, config.domain)  # SceneError for an unknown scene
    for planner in config.planners:
        try:
            RunConfig(
                scene=config.scene,
                planner=planner,
                budget_s=config.budget_s,
                order=config.order,
                max_queries=config.max_queries,
                max_iterations=config.max_iterations,
            )
        except ValueError as exc:
            raise BenchError(f"{planner}: {exc}") from None
    info: dict[str, Any] = {"model": None, "training_seeds": None}
    if not any(config.uses_model(p) for p in config.planners):
        return info
    if config.model == PRIORS:
        return {"model": PRIORS, "training_seeds": None}
    if config.model is None:
        log.warning(
            "no model for domain %r: the learned planner runs on per-stream priors from the "
            "queries recorded in the benchmark's store",
            loaded.name,
        )
        return info
    from planner.learning.model import CostModel

    model = CostModel.load(config.model, domain=loaded)  # ModelError: other domain
    trained: dict[str, list[int]] | None = model.metadata.get("training_seeds")
    info = {"model": config.model, "model_sha256": _sha256(config.model), "training_seeds": trained}
    if trained is None:
        log.warning("model %s does not say which seeds trained it", config.model)
        return info
    seen = sorted(set(trained.get(config.scene, ())) & set(config.seeds))
    if seen:
        shown = ", ".join(map(str, seen[:10])) + (" ..." if len(seen) > 10 else "")
        raise BenchError(
            f"the model {config.model} was trained on {config.scene} seeds {shown}, which this "
            "benchmark would test on: choose --seed-start beyond its training seeds "
            f"(it saw {min(trained[config.scene])}-{max(trained[config.scene])})"
        )
    return info


def code_revision() -> str:
    """The commit of the planner's code (``+dirty`` with uncommitted changes), or its version
    outside a git checkout: what a benchmark's figures were produced with."""
    root = Path(__file__).resolve().parent.parent
    try:
        rev = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "--short=12", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
            timeout=10,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no", "planner"],
            capture_output=True,
            text=True,
            check=True,
            timeout=10,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return f"guided-tamp {__version__}"
    return rev + ("+dirty" if dirty else "")


def _sha256(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def locate_model(config: BenchConfig, sha256: str | None) -> BenchConfig:
    """The benchmark's model file when it is resumed: the recorded path if its content is
    unchanged, else the domain's shipped model if that is the same file (a benchmark started
    from another checkout); a model that changed or is gone is refused, so one benchmark never
    mixes two."""
    if config.model in (None, PRIORS) or sha256 is None:
        return config  # not learned, priors, or recorded before models were hashed
    recorded = Path(config.model)
    if recorded.is_file() and _sha256(recorded) == sha256:
        return config
    shipped = _scene_domain(config.scene, config.domain).spec.model
    if shipped is not None and shipped.is_file() and _sha256(shipped) == sha256:
        log.info("model %s: using the identical shipped model %s", config.model, shipped)
        return replace(config, model=str(shipped))
    state = "has changed" if recorded.is_file() else "is gone"
    raise BenchError(
        f"the benchmark's model {config.model} {state} (it started with sha256 {sha256[:12]}), "
        "and the shipped model is a different one: resume with that model file in place, or "
        "start a new benchmark"
    )


def trial_order(config: BenchConfig) -> list[Trial]:
    """Per seed, every planner; the order of planners alternates between seeds."""
    out = []
    for i, seed in enumerate(config.seeds):
        planners = config.planners if i % 2 == 0 else tuple(reversed(config.planners))
        for planner in planners:
            model = config.model if config.uses_model(planner) else None
            model = get_planner(planner).model or model  # "learned:model=priors"
            out.append(
                Trial(
                    config.scene,
                    seed,
                    planner,
                    config.budget_s,
                    model,
                    config.order,
                    config.domain,
                    config.max_queries,
                    config.max_iterations,
                )
            )
    return out


def _link_finished(
    store: RunStore, bench_id: str, scene: str, done: set[tuple[int, str]]
) -> set[tuple[int, str]]:
    """Trials of a resumed benchmark whose run finished but whose result was never saved (the
    benchmark was killed between the two): recorded now from their runs, so that they are not
    run again; returns their (seed, planner). Runs whose process died unfinished are settled
    first (they are run again)."""
    store.mark_interrupted()
    linked: dict[tuple[int, str], BenchTrialRecord] = {}
    for run in store.runs_tagged(scene, BENCH_KEY, bench_id):
        key = (run.seed, run.planner)
        finished = run.status in ("solved", "timeout") or (
            run.status == "failed" and not run.message.startswith("crashed")
        )
        if key in done or not finished:
            continue
        linked[key] = BenchTrialRecord(
            bench_id=bench_id,
            seed=run.seed,
            planner=run.planner,
            run_id=run.id,
            status=run.status,
            valid=True if run.status == "solved" else None,
            planning_s=run.planning_s,
            execution_s=run.execution_s,
            oracle_s=run.oracle_s,
            queries=run.queries,
            error=run.message if run.status == "failed" else None,
        )
    for trial in linked.values():
        store.record_trial(trial)
        log.info(
            "benchmark %s: seed %d (%s) finished in run %s before the benchmark stopped: kept",
            bench_id,
            trial.seed,
            trial.planner,
            trial.run_id,
        )
    return set(linked)


def create_bench(
    store: RunStore, config: BenchConfig, *, workers: int = 2, ray_address: str | None = None
) -> str:
    """Check a benchmark (:func:`check`) and record it, with no trial run yet; returns its id.
    :func:`run_bench` with ``resume`` runs its trials (the dashboard records a benchmark this
    way, then runs it in a process of its own)."""
    info = check(config)
    return store.create_bench(
        {
            **config.to_dict(),
            **info,
            "workers": workers,
            "ray_address": ray_address,
            "code": code_revision(),
        }
    )


def run_bench(
    db: str | Path,
    config: BenchConfig | None = None,
    *,
    resume: str | None = None,
    workers: int = 2,
    ray_address: str | None = None,
    progress: Callable[[str], None] | None = None,
) -> tuple[str, list[TrialResult]]:
    """Start a benchmark (``config``) or resume one (``resume``); returns its id and the
    results of the trials run now."""
    if (config is None) == (resume is None):
        raise BenchError("give a benchmark configuration or --resume BENCH_ID, not both")
    try:
        check_store_reachable(db, ray_address)
    except StoreUnreachableError as exc:
        raise BenchError(str(exc)) from None
    with RunStore(db) as store:
        if resume is not None:
            try:
                previous = store.get_bench(resume)
            except KeyError as exc:  # the message lists the known benchmarks
                raise BenchError(exc.args[0]) from exc
            config = locate_model(
                BenchConfig.from_dict(previous.config), previous.config.get("model_sha256")
            )
            bench_id = resume
            # A crashed trial (its process or node died) has no outcome: it runs again.
            done = {
                (t.seed, t.planner) for t in store.bench_trials(bench_id) if t.status != CRASHED
            }
            done |= _link_finished(store, bench_id, config.scene, done)
            check(config)  # the scene or the model file may have changed since
            code, started = code_revision(), previous.config.get("code")
            if started is not None and code != started:
                log.warning(
                    "benchmark %s started with code %s and resumes with %s: its trials mix two "
                    "versions of the planner",
                    bench_id,
                    started,
                    code,
                )
        else:
            assert config is not None
            bench_id = create_bench(store, config, workers=workers, ray_address=ray_address)
            done = set()
        store.set_bench_status(bench_id, "running")
    todo = [
        replace(t, bench_id=bench_id)
        for t in trial_order(config)
        if (t.seed, t.planner) not in done
    ]
    log.info("benchmark %s: %d trials to run (%d done before)", bench_id, len(todo), len(done))

    def save(result: TrialResult) -> None:
        with RunStore(db) as s:
            s.record_trial(
                BenchTrialRecord(
                    bench_id=bench_id,
                    seed=result.trial.seed,
                    planner=result.trial.planner,
                    run_id=result.run_id,
                    status=result.status,
                    valid=result.valid,
                    planning_s=result.planning_s,
                    execution_s=result.execution_s,
                    oracle_s=result.oracle_s,
                    queries=result.queries,
                    error=result.error,
                )
            )

    try:
        results = run_trials(
            todo,
            db,
            workers=workers,
            progress=progress,
            on_result=save,
            ray_address=ray_address,
        )
    except BaseException:
        with RunStore(db) as store:
            store.set_bench_status(bench_id, "interrupted")
        raise
    with RunStore(db) as store:
        store.set_bench_status(bench_id, "done")
    return bench_id, results
