"""Batches of trials: many seeds of one scene, each a recorded run, on a local process pool.

Every trial runs in a fresh worker process (OMPL takes one seed per process, so a trial is
reproducible from its seed) and writes its events and stream queries into one SQLite store. A
trial that crashes is recorded as failed with its error, and the batch goes on.
"""

from __future__ import annotations

import logging
import statistics
import sys
import time
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Trial:
    scene: str
    seed: int
    planner: str
    budget_s: float
    model: str | None = None  # model file, for learned planners


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
    from planner.runs import RunConfig, record_run
    from planner.store import RunStore

    store = RunStore(db)
    config = RunConfig(
        scene=trial.scene,
        seed=trial.seed,
        planner=trial.planner,
        budget_s=trial.budget_s,
        model=trial.model,
    )
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
) -> list[TrialResult]:
    """Run ``trials`` on a process pool, recording each into ``db``; in completion order."""
    from planner.store import RunStore

    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    RunStore(db).close()  # create the schema once, before workers race to it
    say = progress or (lambda _m: None)
    results: list[TrialResult] = []
    start = time.perf_counter()
    with ProcessPoolExecutor(max_workers=workers, max_tasks_per_child=1) as pool:
        futures = [pool.submit(run_trial, t, str(db)) for t in trials]
        for done, fut in enumerate(as_completed(futures), 1):
            r = fut.result()
            results.append(r)
            elapsed = time.perf_counter() - start
            solved = [x for x in results if x.status == "solved"]
            eta = elapsed / done * (len(trials) - done)
            median = statistics.median(x.planning_s or 0 for x in solved) if solved else 0.0
            say(
                f"[{done}/{len(trials)}] solved {len(solved)}, median planning {median:.0f} s, "
                f"elapsed {_fmt(elapsed)}, about {_fmt(eta)} left"
            )
    return results


def stderr_progress(message: str) -> None:
    """A live line on a terminal, plain lines otherwise."""
    if sys.stderr.isatty():
        sys.stderr.write(f"\r\033[K{message}")
    else:
        sys.stderr.write(message + "\n")
    sys.stderr.flush()
