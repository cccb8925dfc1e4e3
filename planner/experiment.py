"""Batches of trials: many seeds of one scene, each a recorded run, on local processes or Ray.

Every trial runs in a fresh worker process (OMPL takes one seed per process, so a trial is
reproducible from its seed) and writes its events and stream queries into one store. A trial
whose planner raises is failed with its error; one whose process or Ray node dies is
``crashed`` with the reason (its run, if it had begun, is finished as failed with it), and the
batch goes on: ``tamp bench --resume`` runs crashed trials again.
"""

from __future__ import annotations

import logging
import os
import statistics
import sys
import time
import traceback
import uuid
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from multiprocessing.connection import Connection, wait
from multiprocessing.process import BaseProcess
from pathlib import Path
from typing import Any

from planner.status import CRASHED

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
    max_queries: int | None = None  # RunConfig.max_queries
    max_iterations: int | None = None  # RunConfig.max_iterations
    # The benchmark the trial belongs to, recorded with its run: a resumed benchmark finds a
    # run that finished when its result could not be saved (its benchmark killed in between).
    bench_id: str | None = None

    def run_fields(self) -> dict[str, Any]:
        """The trial's fields that are :class:`~planner.api.RunConfig`'s (all but its bench)."""
        fields = asdict(self)
        del fields["bench_id"]
        return fields


@dataclass(frozen=True)
class TrialResult:
    trial: Trial
    run_id: str | None
    status: str  # a TrialStatus (planner.status): solved, timeout, failed, or CRASHED
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


BENCH_KEY = "bench_id"  # the key of a trial's benchmark in its run's stored configuration
LOCAL_RAY = "local"  # --ray-address for a Ray started in this process, on this machine


class StoreUnreachableError(ValueError):
    """Trials would run where the store cannot be reached; the message says what to give."""


def check_store_reachable(db: str | Path, ray_address: str | None) -> None:
    """A SQLite store is a file on this machine: trials on a Ray cluster's other nodes could not
    write to it (each would find, or create, a file of its own there). Refused before any trial
    runs, naming what to give instead."""
    if ray_address is None or ray_address == LOCAL_RAY:
        return
    from sqlalchemy import make_url

    text = str(db)
    backend = make_url(text).get_backend_name() if "://" in text else "sqlite"
    if backend == "sqlite":
        raise StoreUnreachableError(
            f"the store {text} is a SQLite file on this machine, which the nodes of the Ray "
            f"cluster at {ray_address!r} cannot write to: give --db a database every node "
            "reaches (postgresql+psycopg://USER@HOST/DB), or --ray-address local to run the "
            "trials on this machine"
        )


def run_trial(trial: Trial, db: str, run_id: str | None = None) -> TrialResult:
    """One recorded run (in the calling process), stored under ``run_id`` (default: a new id);
    a planner that raises makes a failed result."""
    from planner.runs import preload_libraries, record_run, resolve_run
    from planner.store import RunStore

    store = RunStore(db)
    config = resolve_run(db, **trial.run_fields())
    preload_libraries(config)
    stored = asdict(config)
    if trial.bench_id is not None:
        stored[BENCH_KEY] = trial.bench_id
    run_id = store.create_run(trial.scene, trial.seed, trial.planner, stored, run_id=run_id)
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
    process or node dies is a ``crashed`` result with the reason; ``on_result`` sees every
    result as it comes. On a Ray cluster (any address but ``local``) ``db`` must be a database
    every node reaches, a PostgreSQL URL: a SQLite path is refused before any trial runs.
    """
    from planner.store import RunStore

    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    check_store_reachable(db, ray_address)
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


def _crashed(trial: Trial, db: str, run_id: str, reason: str) -> TrialResult:
    """The result of a trial whose process or node died; its run, if it had begun, is finished
    as failed with the reason (nobody else would: its process is gone)."""
    from planner.store import RunStore

    log.warning("trial %s seed %d (%s) crashed: %s", trial.scene, trial.seed, trial.planner, reason)
    recorded: str | None = run_id
    try:
        with RunStore(db) as store:
            store.settle_run(run_id, "failed", f"crashed: {reason}")
    except KeyError:
        recorded = None  # it died before it recorded its run
    return TrialResult(trial, recorded, CRASHED, None, None, None, None, 0, 0.0, reason)


def _trial_process(trial: Trial, db: str, run_id: str, conn: Connection) -> None:
    """Entry point of a local trial process: the result goes back through ``conn``."""
    logging.basicConfig(level=logging.WARNING)
    result: TrialResult | str
    try:
        result = run_trial(trial, db, run_id)
    except BaseException as exc:  # even Ctrl-C: the parent decides what happens next
        result = f"{type(exc).__name__}: {exc}"
    conn.send(result)
    conn.close()


def _run_local(
    trials: Sequence[Trial], db: str, workers: int, done: Callable[[TrialResult], None]
) -> None:
    from planner import supervise

    ctx = supervise.context()
    pending = deque(trials)
    running: dict[Connection, tuple[BaseProcess, Trial, str]] = {}
    try:
        while pending or running:
            while pending and len(running) < workers:
                trial = pending.popleft()
                run_id = uuid.uuid4().hex
                receive, send = ctx.Pipe(duplex=False)
                # A fresh interpreter (OMPL seeds per process) that ends with this one.
                proc = supervise.spawn(
                    _trial_process,
                    trial,
                    db,
                    run_id,
                    send,
                    what=f"trial {trial.scene} seed {trial.seed} ({trial.planner})",
                )
                send.close()
                running[receive] = (proc, trial, run_id)
            for conn in wait(list(running), timeout=1.0):
                assert isinstance(conn, Connection)
                process, trial, run_id = running.pop(conn)
                try:
                    got: TrialResult | str = conn.recv()
                except (EOFError, OSError):
                    process.join(timeout=5.0)
                    got = f"the trial's process died (exit code {process.exitcode})"
                conn.close()
                process.join(timeout=5.0)
                done(got if isinstance(got, TrialResult) else _crashed(trial, db, run_id, got))
    finally:
        for left, _, _ in running.values():  # interrupted: stop what still runs
            left.terminate()
        for left, _, _ in running.values():
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
            if address == LOCAL_RAY:
                # Ray runs its workers at nice 15; on a machine with other work the trials
                # then starve (a 1 s top-k call took 86 s beside a running benchmark), and
                # they would not be timed like the process pool's trials, which run at 0.
                os.environ.setdefault("RAY_worker_niceness", "0")
                # address="local": a Ray of its own even when another runs on this machine (a
                # cluster left behind, or RAY_ADDRESS set), which ray.init() would join instead.
                ray.init(
                    address="local",
                    num_cpus=workers,
                    include_dashboard=False,
                    log_to_driver=False,
                )
            else:
                ray.init(address=address, log_to_driver=False)
        except Exception as exc:  # no trial has started: the benchmark resumes once Ray is up
            raise ValueError(
                f"cannot reach a Ray cluster at {address!r} ({type(exc).__name__}: {exc}); "
                "give an address, 'auto' for the cluster this machine belongs to, or 'local'"
            ) from exc
    try:
        # A fresh worker process per trial (max_calls=1), no silent retries: a trial runs once.
        # The trials write to the store themselves: a database every node reaches
        # (check_store_reachable), so what a node records survives the node.
        remote = ray.remote(num_cpus=1, max_calls=1, max_retries=0)(_ray_trial)
        refs: dict[Any, tuple[Trial, str]] = {}
        for t in trials:
            run_id = uuid.uuid4().hex
            refs[remote.remote(t, db, run_id)] = (t, run_id)
        while refs:
            ready, _ = ray.wait(list(refs), num_returns=1)
            for ref in ready:
                trial, run_id = refs.pop(ref)
                try:
                    result = ray.get(ref)
                except Exception as exc:  # its worker or node died: no result came back
                    reason = f"the Ray task failed: {type(exc).__name__}: {_first_line(exc)}"
                    result = _crashed(trial, db, run_id, reason)
                done(result)
    finally:
        if started_here:
            ray.shutdown()


def _ray_trial(trial: Trial, db: str, run_id: str) -> TrialResult:
    """A Ray task: :func:`run_trial` in a Ray worker."""
    return run_trial(trial, db, run_id)


def _first_line(exc: BaseException) -> str:
    """Ray's errors run to many lines (tracebacks, advice); the first says what happened."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return lines[0] if lines else "no message"


def stderr_progress(message: str) -> None:
    """A live line on a terminal, plain lines otherwise."""
    if sys.stderr.isatty():
        sys.stderr.write(f"\r\033[K{message}")
    else:
        sys.stderr.write(message + "\n")
    sys.stderr.flush()
