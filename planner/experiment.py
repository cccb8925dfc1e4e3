"""Batches of trials: many seeds of one scene, each a recorded run, on local processes or Ray.

Every trial runs in a fresh worker process (OMPL takes one seed per process, so a trial is
reproducible from its seed) and writes its events and stream queries into one store. A trial
that crashes (or whose process dies) is recorded as failed with its error, and the batch goes
on.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import statistics
import sys
import time
import traceback
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from multiprocessing.connection import Connection, wait
from multiprocessing.process import BaseProcess
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Trial:
    scene: str
    seed: int
    planner: str
    budget_s: float
    model: str | None = None  # model file, for learned planners (and --order model)
    order: str = "auto"  # stream order (RunConfig.order)
    domain: str | None = None  # the domain's name or folder (RunConfig.domain)


@dataclass(frozen=True)
class TrialResult:
    trial: Trial
    run_id: str | None
    status: str  # solved, timeout, failed
    valid: bool | None
    planning_s: float | None
    execution_s: float | None
    oracle_s: float | None
    queries: int
    record_s: float  # seconds spent handing events to the store
    error: str | None = None

    def to_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out.update(asdict(self.trial))
        del out["trial"]
        return out


def run_trial(trial: Trial, db: str) -> TrialResult:
    """One recorded run (in the calling process); crashes become failed results."""
    from planner.runs import RunConfig, preload_libraries, record_run
    from planner.store import RunStore

    store = RunStore(db)
    config = RunConfig(
        scene=trial.scene,
        seed=trial.seed,
        planner=trial.planner,
        budget_s=trial.budget_s,
        model=trial.model,
        order=trial.order,
        domain=trial.domain,
        # A learned trial with no model for its domain runs on the priors of this store.
        priors_db=db if trial.model is None else None,
    )
    preload_libraries(config)
    run_id = store.create_run(trial.scene, trial.seed, trial.planner, asdict(config))
    try:
        recorded = record_run(config, store, run_id)
    except Exception as exc:  # a crashed trial is data, not the end of the batch
        error = f"{type(exc).__name__}: {exc}"
        log.warning("trial %s seed %d crashed: %s", trial.scene, trial.seed, error)
        log.debug("%s", traceback.format_exc())
        return TrialResult(trial, run_id, "failed", None, None, None, None, 0, 0.0, error)
    finally:
        store.close()
    result = recorded.result
    return TrialResult(
        trial,
        run_id,
        recorded.status,
        recorded.valid,
        result.planning_s,
        result.execution_s,
        result.oracle_s,
        len(result.queries),
        recorded.record_s,
    )


def _fmt(seconds: float) -> str:
    return f"{seconds / 60:.0f} min" if seconds >= 120 else f"{seconds:.0f} s"


def run_trials(
    trials: Sequence[Trial],
    db: str | Path,
    *,
    workers: int = 2,
    progress: Callable[[str], None] | None = None,
    on_result: Callable[[TrialResult], None] | None = None,
    ray_address: str | None = None,
) -> list[TrialResult]:
    """Run ``trials``, recording each into ``db``; results in completion order.

    Locally each trial gets a fresh spawned process (at most ``workers`` at once); with
    ``ray_address`` (an address, ``auto``, or ``local`` for a Ray started here with
    ``workers`` CPUs) each trial is a Ray task in a fresh worker process. A trial whose
    process dies is a failed result with the exit code; ``on_result`` sees every result as it
    comes. On a multi-machine Ray cluster ``db`` must be a database every node reaches
    (a PostgreSQL URL or a shared file system).
    """
    from planner.store import RunStore

    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    RunStore(db).close()  # create the schema once, before workers race to it
    say = progress or (lambda _m: None)
    results: list[TrialResult] = []
    start = time.perf_counter()

    def done(r: TrialResult) -> None:
        results.append(r)
        if on_result is not None:
            on_result(r)
        elapsed = time.perf_counter() - start
        eta = elapsed / len(results) * (len(trials) - len(results))
        parts = []
        for planner in dict.fromkeys(x.trial.planner for x in results):  # first-seen order
            mine = [x for x in results if x.trial.planner == planner]
            solved = [x.planning_s or 0.0 for x in mine if x.status == "solved"]
            median = f"{statistics.median(solved):.0f} s" if solved else "-"
            parts.append(f"{planner} {len(solved)}/{len(mine)} solved (median planning {median})")
        say(
            f"[{len(results)}/{len(trials)}] {', '.join(parts)}; elapsed {_fmt(elapsed)}, "
            f"about {_fmt(eta)} left"
        )

    if ray_address is None:
        _run_local(trials, str(db), workers, done)
    else:
        _run_ray(trials, str(db), ray_address, workers, done)
    return results


def _crashed(trial: Trial, error: str) -> TrialResult:
    log.warning("trial %s seed %d (%s): %s", trial.scene, trial.seed, trial.planner, error)
    return TrialResult(trial, None, "failed", None, None, None, None, 0, 0.0, error)


def _trial_process(trial: Trial, db: str, conn: Connection) -> None:
    """Entry point of a local trial process: the result goes back through ``conn``."""
    logging.basicConfig(level=logging.WARNING)
    try:
        result = run_trial(trial, db)
    except BaseException as exc:  # even Ctrl-C: the parent decides what happens next
        result = _crashed(trial, f"{type(exc).__name__}: {exc}")
    conn.send(result)
    conn.close()


def _run_local(
    trials: Sequence[Trial], db: str, workers: int, done: Callable[[TrialResult], None]
) -> None:
    ctx = multiprocessing.get_context("spawn")  # a fresh interpreter: OMPL seeds per process
    pending = deque(trials)
    running: dict[Connection, tuple[BaseProcess, Trial]] = {}
    try:
        while pending or running:
            while pending and len(running) < workers:
                trial = pending.popleft()
                receive, send = ctx.Pipe(duplex=False)
                proc: BaseProcess = ctx.Process(
                    target=_trial_process, args=(trial, db, send), daemon=True
                )
                proc.start()
                send.close()
                running[receive] = (proc, trial)
            for conn in wait(list(running), timeout=1.0):
                assert isinstance(conn, Connection)
                process, trial = running.pop(conn)
                try:
                    result = conn.recv()
                except (EOFError, OSError):
                    process.join(timeout=5.0)
                    result = _crashed(
                        trial, f"the trial's process died (exit code {process.exitcode})"
                    )
                conn.close()
                process.join(timeout=5.0)
                done(result)
    finally:
        for left, _ in running.values():  # interrupted: stop what still runs
            left.terminate()
        for left, _ in running.values():
            left.join(timeout=5.0)


def _run_ray(
    trials: Sequence[Trial],
    db: str,
    address: str,
    workers: int,
    done: Callable[[TrialResult], None],
) -> None:
    import ray

    started_here = not ray.is_initialized()
    if started_here:
        try:
            if address == "local":
                # Ray runs its workers at nice 15; on a machine with other work the trials
                # then starve (a 1 s top-k call took 86 s beside a running benchmark), and
                # they would not be timed like the process pool's trials, which run at 0.
                os.environ.setdefault("RAY_worker_niceness", "0")
                ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
            else:
                ray.init(address=address, log_to_driver=False)
        except Exception as exc:  # no trial has started: the benchmark resumes once Ray is up
            raise ValueError(
                f"cannot reach a Ray cluster at {address!r} ({type(exc).__name__}: {exc}); "
                "give an address, 'auto' for the cluster this machine belongs to, or 'local'"
            ) from exc
    try:
        # A fresh worker process per trial (max_calls=1), no silent retries: a trial runs once.
        remote = ray.remote(num_cpus=1, max_calls=1, max_retries=0)(run_trial)
        refs = {remote.remote(t, db): t for t in trials}
        while refs:
            ready, _ = ray.wait(list(refs), num_returns=1)
            for ref in ready:
                trial = refs.pop(ref)
                try:
                    result = ray.get(ref)
                except Exception as exc:
                    result = _crashed(trial, f"Ray task failed: {type(exc).__name__}: {exc}")
                done(result)
    finally:
        if started_here:
            ray.shutdown()


def stderr_progress(message: str) -> None:
    """A live line on a terminal, plain lines otherwise."""
    if sys.stderr.isatty():
        sys.stderr.write(f"\r\033[K{message}")
    else:
        sys.stderr.write(message + "\n")
    sys.stderr.flush()
