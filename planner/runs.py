"""Recorded runs: a planning run (:func:`planner.api.solve`) whose every event goes to the run
store, with its plan validated and the run finished in the store however it ends.

:func:`run` is :func:`planner.api.solve` returning ``(result, domain, problem)``;
:func:`record_run` is what ``tamp plan``, ``tamp collect``/``bench`` trials and the dashboard's
workers call.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from planner.api import RunConfig, RunResult, solve
from planner.domains import LoadedDomain
from planner.events import EventSink, FanOutSink
from planner.pddl.structs import Problem
from planner.planners import DEFAULT_PLANNER, ORDERS, PLANNERS, plan_summaries
from planner.status import SearchStatus

if TYPE_CHECKING:
    from planner.store import RunStore

log = logging.getLogger(__name__)

__all__ = [
    "DEFAULT_PLANNER",
    "ORDERS",
    "PLANNERS",
    "RecordedRun",
    "RunConfig",
    "RunResult",
    "plan_summaries",
    "preload_libraries",
    "record_run",
    "resolve_run",
    "run",
]


def resolve_run(db: str | Path | None, **fields: Any) -> RunConfig:
    """The one configuration of a run recorded into the store ``db``: the CLI (``tamp plan``),
    the dashboard and benchmark trials each make theirs here, from :class:`RunConfig`'s own
    fields (a ``ValueError`` names a bad one), and pass it whole to the process that runs it.

    What is decided here and nowhere else: a run that plans on per-stream priors (learned with
    no model for its domain, or ``model="priors"``) takes them from the queries recorded in
    its own store (:func:`planner.planners.load_predictor` reads ``priors_db`` only then)."""
    if "priors_db" in fields:
        raise TypeError("priors_db is the run's store: give db")
    return RunConfig(**fields, priors_db=None if db is None else str(db))


def preload_libraries(config: RunConfig) -> None:
    """Import what ``config``'s planner needs before its clock starts.

    Libraries are process set-up for every planner, not planning: the baseline's (the top-k
    planner, and what a domain's samplers import when they are bound) come before any run, and a
    server imports each once. The model's (torch) were imported lazily inside the run, so a fresh
    process charged a learned run about 3 s of torch import (4.5 s under load) as planning. The
    domains are imported here too: finding a scene by name imports every installed domain
    (the kitchen's pybullet among them), 1 to 2 s that a fresh trial process charged every
    planner alike. Reading the scene, building its problem and reading the model file stay
    inside the clock. A scene or domain that cannot load is left for the run to report.
    """
    if config.uses_model:
        import planner.learning.predictor  # noqa: F401
    from planner.domains import domain_of_scene, find_scene, load_domain

    try:
        given = load_domain(config.domain) if config.domain is not None else None
        domain_of_scene(find_scene(config.scene, domain=given), given)
    except Exception as exc:  # the run itself reports what is wrong, as a failed run
        log.debug("preloading %s: %s", config.scene, exc)


def run(
    config: RunConfig,
    *,
    sink: EventSink | None = None,
    run_id: str | None = None,
    progress: Callable[[str], None] | None = None,
    should_stop: Callable[[], bool] | None = None,
) -> tuple[RunResult, LoadedDomain, Problem]:
    """Plan ``config.scene``; every step is reported to ``sink``."""
    out = solve(config, sink=sink, run_id=run_id, progress=progress, should_stop=should_stop)
    return out.result, out.loaded, out.problem


@dataclass(frozen=True)
class RecordedRun:
    """A run and what was stored about it: its final status, validation and plan file."""

    result: RunResult
    loaded: LoadedDomain
    problem: Problem
    status: SearchStatus  # stored: the search's, or failed when the plan does not validate
    valid: bool | None  # None when there is no plan
    message: str
    plan: dict[str, Any] | None  # the bound plan file when solved
    record_s: float  # seconds the planner spent handing events to the store
    writer_cpu_s: float = 0.0  # CPU seconds the store's writer thread spent beside the planner


def record_run(
    config: RunConfig,
    store: RunStore,
    run_id: str,
    *,
    sinks: tuple[EventSink, ...] = (),
    progress: Callable[[str], None] | None = None,
    should_stop: Callable[[], bool] | None = None,
    stop_reason: Callable[[], str] | None = None,
) -> RecordedRun:
    """Run ``config`` as the stored run ``run_id``: every event goes to the store (and to
    ``sinks``), the plan is validated, and the run is finished in the store however it ends.
    An exception or Ctrl-C finishes the run as failed / cancelled, keeps its events, and
    propagates. A run ``should_stop`` stopped is cancelled for the reason ``stop_reason``
    gives (:func:`planner.api.solve`; default: by the user)."""
    from planner.store import StoreSink

    sink = _Tee(StoreSink(store, run_id), FanOutSink(*sinks))
    try:
        out = solve(
            config,
            sink=sink,
            run_id=run_id,
            progress=progress,
            should_stop=should_stop,
            stop_reason=stop_reason,
        )
    except KeyboardInterrupt:
        sink.close()
        store.finish_run(run_id, "cancelled", message="interrupted by the user")
        raise
    except Exception as exc:
        sink.close()
        store.finish_run(run_id, "failed", message=f"{type(exc).__name__}: {exc}")
        raise
    sink.close()
    result, loaded, problem = out.result, out.loaded, out.problem
    valid, message = out.check()  # validated by solve(), before its run_finished
    plan = out.plan_file()
    if result.status == "cancelled":
        message = out.message  # why it was stopped: solve() said so in its run_cancelled
    status = out.status
    store.finish_run(
        run_id,
        status,
        planning_s=result.planning_s,
        execution_s=result.execution_s,
        oracle_s=result.oracle_s,
        queries=len(result.queries),
        message=message,
        plan=plan,
    )
    writer = sink.primary.writer_cpu_s if isinstance(sink.primary, StoreSink) else 0.0
    return RecordedRun(
        result, loaded, problem, status, valid, message, plan, sink.primary_s, writer
    )


class _Tee:
    """The store first (its errors propagate: a run that cannot be recorded stops), then the
    listeners (isolated by a :class:`FanOutSink`)."""

    def __init__(self, primary: EventSink, listeners: FanOutSink) -> None:
        self.primary = primary
        self.listeners = listeners
        self.primary_s = 0.0  # seconds spent in the primary sink

    def emit(self, event: Any) -> None:
        t = time.perf_counter()
        self.primary.emit(event)
        self.primary_s += time.perf_counter() - t
        if self.listeners.sinks:
            self.listeners.emit(event)

    def close(self) -> None:
        t = time.perf_counter()
        try:
            self.primary.close()
        finally:
            self.primary_s += time.perf_counter() - t
            self.listeners.close()
