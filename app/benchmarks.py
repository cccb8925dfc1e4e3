"""Benchmarks on the dashboard: every benchmark of the store with its progress (those of
``tamp bench`` too), one benchmark's summary as ``tamp report`` computes it, and benchmarks
launched, cancelled and resumed from the page.

A benchmark launched here is checked and recorded in the request (``planner.bench.create_bench``:
the scene, the planners, the model and its training seeds), then run by a worker process of its
own (``app/bench_worker.py``: ``run_bench`` resuming it, the code of ``tamp bench --resume``),
whose trials run in processes of their own. Cancelling stops the worker the way Ctrl-C stops
``tamp bench``: the finished trials are kept and the benchmark can be resumed, here or with
``tamp bench --resume``. At most ``max_running`` benchmarks run from the dashboard at once.
A benchmark whose process died (a killed ``tamp bench``, a crashed server) is marked
``interrupted`` within ``sweep_s``.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from datetime import datetime
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from pathlib import Path
from typing import Any

from app import bench_worker, catalog
from app.errors import BusyError, NotLiveError, RequestError
from planner import supervise
from planner.bench import BenchConfig, BenchError, create_bench, make_config
from planner.planners import get_planner
from planner.report import summarize
from planner.scene import SceneError
from planner.store import BenchRecord, RunStore, is_alive

log = logging.getLogger(__name__)

KEPT_SUMMARIES = 16  # benchmark summaries kept while their trials are unchanged


@dataclass(frozen=True)
class PlannerProgress:
    done: int  # trials finished (solved, timeout or failed)
    solved: int


@dataclass(frozen=True)
class BenchInfo:
    """A benchmark as the list shows it."""

    id: str
    scene: str
    planners: list[str]
    seeds: int
    seed_first: int
    seed_last: int
    budget_s: float
    model: str | None  # the model file's name
    order: str
    status: str  # running, done, interrupted, cancelled
    created_at: datetime
    finished_at: datetime | None
    done: int  # trials finished
    total: int  # trials in all (seeds x planners)
    progress: dict[str, PlannerProgress]
    runner: str | None  # "dashboard" (this server runs it), "elsewhere" (tamp bench), or None
    message: str  # why it stopped, when it stopped on an error


@dataclass
class _Worker:
    bench_id: str
    process: BaseProcess
    conn: Connection
    started: float = field(default_factory=time.monotonic)
    cancel_at: float | None = None  # the user asked to cancel it
    stop_at: float | None = None  # it was asked to stop (cancelled, or the server shuts down)
    outcome: tuple[str, str | None] | None = None
    ended: bool = False  # its ending is being recorded


def _info(
    record: BenchRecord,
    counts: dict[str, dict[str, int]],
    runner: str | None,
    message: str,
    model_names: Mapping[str, str] | None = None,
) -> BenchInfo:
    config = record.config
    planners = [str(p) for p in config.get("planners", [])]
    seeds = [int(s) for s in config.get("seeds", [])]
    progress = {
        p: PlannerProgress(sum(counts.get(p, {}).values()), counts.get(p, {}).get("solved", 0))
        for p in planners
    }
    model = config.get("model")
    return BenchInfo(
        id=record.id,
        scene=str(config.get("scene", "")),
        planners=planners,
        seeds=len(seeds),
        seed_first=min(seeds) if seeds else 0,
        seed_last=max(seeds) if seeds else 0,
        budget_s=float(config.get("budget_s", 0.0)),
        model=_model_name(model, model_names or {}) if isinstance(model, str) else None,
        order=str(config.get("order", "auto")),
        status=record.status,
        created_at=record.created_at,
        finished_at=record.finished_at,
        done=sum(p.done for p in progress.values()),
        total=len(seeds) * len(planners),
        progress=progress,
        runner=runner,
        message=message,
    )


def _model_name(path: str, names: Mapping[str, str]) -> str:
    """The name the models page offers the file at ``path`` by (a shipped model's is its
    domain's: every domain's file is ``model.pt``, and "model model" said nothing), else its
    file's stem."""
    try:
        resolved = str(Path(path).resolve())
    except OSError:
        resolved = path
    return names.get(resolved, Path(path).stem)


def _field_of(error: str) -> str:
    """The request field a :class:`BenchError` message is about."""
    for flag, name in (
        ("--trials", "trials"),
        ("--seed-start", "seed_start"),
        ("--budget", "budget_s"),
        ("--model", "model"),
        ("--order", "order"),
        ("--max-queries", "max_queries"),
        ("--max-iterations", "max_iterations"),
        ("trained on", "seed_start"),
    ):
        if flag in error:
            return name
    return "planners"


class BenchService:
    def __init__(
        self,
        store: RunStore,
        database: str,
        domains: catalog.Domains,
        models: catalog.Models,
        *,
        max_running: int = 1,
        cancel_grace_s: float = 30.0,
        sweep_s: float = 2.0,
    ) -> None:
        self.store = store
        self.database = database
        self.domains = domains
        self.models = models
        self.max_running = max_running
        self.cancel_grace_s = cancel_grace_s
        self.sweep_s = sweep_s
        self._ctx = supervise.context()
        self._lock = threading.RLock()
        self._workers: dict[str, _Worker] = {}
        self._messages: dict[str, str] = {}  # why a benchmark of this server stopped
        self._summaries: OrderedDict[tuple[Any, ...], dict[str, Any]] = OrderedDict()
        self._closing = threading.Event()
        self._thread = threading.Thread(target=self._watch, name="benchmarks", daemon=True)
        self._thread.start()

    # --- reading -----------------------------------------------------------------------------

    def listed(self) -> list[tuple[BenchRecord, BenchInfo]]:
        """Every benchmark of the store, newest first: its record (the whole configuration)
        and what the list shows of it."""
        counts = self.store.bench_progress()
        names = self._model_names()
        return [(r, self._with(r, counts.get(r.id, {}), names)) for r in self.store.list_benches()]

    def list(self) -> list[BenchInfo]:
        """Every benchmark of the store, newest first, with its progress."""
        return [info for _, info in self.listed()]

    def get(self, bench_id: str) -> BenchInfo:
        """KeyError (listing the known ones) for an unknown benchmark."""
        record = self.store.get_bench(bench_id)
        return self._with(record, self.store.bench_progress().get(bench_id, {}))

    def summary(self, bench_id: str) -> tuple[BenchInfo, dict[str, Any]]:
        """The benchmark and :func:`planner.report.summarize` of it (the figures of
        ``tamp report``), kept while its trials and status are unchanged."""
        info = self.get(bench_id)
        key = self.summary_key(info)
        with self._lock:
            kept = self._summaries.get(key)
            if kept is not None:
                self._summaries.move_to_end(key)
                return info, kept
        summary = summarize(self.database, bench_id)
        with self._lock:
            self._summaries[key] = summary
            while len(self._summaries) > KEPT_SUMMARIES:
                self._summaries.popitem(last=False)
        return info, summary

    @staticmethod
    def summary_key(info: BenchInfo) -> tuple[Any, ...]:
        """What a benchmark's summary depends on: while it is unchanged, a kept one is right."""
        return (
            info.id,
            info.status,
            tuple(sorted((p, v.done, v.solved) for p, v in info.progress.items())),
        )

    def _with(
        self,
        record: BenchRecord,
        counts: dict[str, dict[str, int]],
        names: Mapping[str, str] | None = None,
    ) -> BenchInfo:
        with self._lock:
            worker = self._workers.get(record.id)
            message = self._messages.get(record.id, "")
        runner = None
        if worker is not None:
            runner = "dashboard"
            # A worker told to stop leaves its benchmark "interrupted" in the store as it
            # exits; it is "running" (stopping) until the server has reaped it and said how
            # it ended ("cancelled" for a cancel), never "interrupted" for a moment first.
            if worker.stop_at is not None:
                record = replace(record, status="running")
                if worker.cancel_at is not None:
                    message = "cancelling: the running trials are being stopped"
        elif record.status == "running" and is_alive(record.owner):
            runner = "elsewhere"
        return _info(record, counts, runner, message, names or self._model_names())

    def _model_names(self) -> dict[str, str]:
        """Model file (resolved) -> the name the page offers it by."""
        try:
            return {str(p.resolve()): name for name, p in self.models.files().items()}
        except Exception:  # a domain that does not load: its files by their stems
            log.exception("could not list the model files")
            return {}

    # --- launching, cancelling, resuming -----------------------------------------------------

    def launch(
        self,
        *,
        scene: str,
        planners: Sequence[str],
        trials: int,
        seed_start: int,
        budget_s: float,
        model: str | None,
        workers: int,
        order: str = "auto",
        max_queries: int | None = None,
        max_iterations: int | None = None,
    ) -> BenchInfo:
        """Check, record and start a benchmark; :class:`RequestError` names the bad field,
        :class:`BusyError` when the dashboard already runs as many as it may."""
        from planner.learning.model import ModelError  # torch: only once a benchmark starts

        config = self._config(
            scene,
            planners,
            trials,
            seed_start,
            budget_s,
            model,
            order,
            max_queries=max_queries,
            max_iterations=max_iterations,
        )
        with self._lock:
            self._check_room()
            try:
                bench_id = create_bench(self.store, config, workers=workers)
            except BenchError as exc:
                raise RequestError(_field_of(str(exc)), str(exc)) from exc
            except SceneError as exc:
                raise RequestError("scene", str(exc)) from exc
            except ModelError as exc:  # a model file of another domain, or unreadable
                raise RequestError("model", str(exc)) from exc
            self._start(bench_id, workers)
        log.info("benchmark %s started from the dashboard (%s, %s)", bench_id, scene, planners)
        return self.get(bench_id)

    def _config(
        self,
        scene: str,
        planners: Sequence[str],
        trials: int,
        seed_start: int,
        budget_s: float,
        model: str | None,
        order: str,
        *,
        max_queries: int | None = None,
        max_iterations: int | None = None,
    ) -> BenchConfig:
        try:
            info = self.domains.scene(scene)
        except catalog.UnknownNameError as exc:
            raise RequestError("scene", str(exc)) from exc
        names = [p.strip() for p in planners]
        for i, name in enumerate(names):
            try:
                get_planner(name)
            except ValueError as exc:
                raise RequestError(["planners", i], str(exc)) from exc
            if names.index(name) != i:
                raise RequestError(["planners", i], f"planner {name!r} is listed twice")
        if not names:
            raise RequestError("planners", "name at least one planner")
        path: str | None = None
        if model is not None:
            if not any(get_planner(p).uses_model for p in names) and order != "model":
                raise RequestError("model", "a model is only used by the learned planners")
            try:
                path = str(self.models.path(model))
            except catalog.UnknownNameError as exc:
                raise RequestError("model", str(exc)) from exc
            domain = self.models.domain_of(model)
            if domain != info.domain:
                raise RequestError(
                    "model",
                    f"model {model!r} is for domain {domain!r}, scene {scene!r} is {info.domain!r}",
                )
        try:
            return make_config(
                scene,
                names,
                trials=trials,
                seed_start=seed_start,
                budget_s=budget_s,
                model=path,
                order=order,
                domain=info.domain_ref,
                max_queries=max_queries,
                max_iterations=max_iterations,
            )
        except BenchError as exc:
            raise RequestError(_field_of(str(exc)), str(exc)) from exc

    def resume(self, bench_id: str, workers: int) -> BenchInfo:
        """Run the missing trials of a stopped benchmark; KeyError for an unknown one,
        :class:`NotLiveError` when it runs or has nothing left to run."""
        info = self.get(bench_id)
        if info.status == "running":
            raise NotLiveError(f"benchmark {bench_id} is running ({info.runner or 'somewhere'})")
        if info.done >= info.total:
            raise NotLiveError(f"benchmark {bench_id} has run all its {info.total} trials")
        with self._lock:
            self._check_room()
            self.store.set_bench_status(bench_id, "running")  # owned here until its worker runs
            self._messages.pop(bench_id, None)
            self._start(bench_id, workers)
        log.info("benchmark %s resumed from the dashboard", bench_id)
        return self.get(bench_id)

    def cancel(self, bench_id: str) -> BenchInfo:
        """Stop a benchmark this server runs, keeping its finished trials; KeyError for an
        unknown one, :class:`NotLiveError` when it is not running here."""
        info = self.get(bench_id)
        with self._lock:
            worker = self._workers.get(bench_id)
            if info.status != "running":
                raise NotLiveError(f"benchmark {bench_id} is not running ({info.status})")
            if worker is None:
                if info.runner == "elsewhere":
                    raise NotLiveError(
                        f"benchmark {bench_id} is run by another process (tamp bench); stop "
                        "it there (Ctrl-C), then resume it here or with tamp bench --resume"
                    )
                raise NotLiveError(f"benchmark {bench_id} is not running ({info.status})")
            if worker.cancel_at is None:
                worker.cancel_at = worker.stop_at = time.monotonic()
                worker.process.terminate()  # SIGTERM: stops like Ctrl-C (bench_worker.py)
                log.info("benchmark %s: cancel requested", bench_id)
        return self.get(bench_id)

    def running(self) -> int:
        with self._lock:
            return len(self._workers)

    def close(self, timeout_s: float = 10.0) -> None:
        """Stop the benchmarks this server runs (each resumable)."""
        self._closing.set()
        with self._lock:
            for worker in self._workers.values():
                if worker.stop_at is None:
                    worker.stop_at = time.monotonic()
                    worker.process.terminate()
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with self._lock:
                if not self._workers:
                    break
            time.sleep(0.05)
        self._thread.join(timeout=2.0)
        with self._lock:
            for worker in list(self._workers.values()):
                if worker.process.is_alive():
                    worker.process.kill()
                self._ended(worker, "the server shut down")

    def _check_room(self) -> None:
        if self._closing.is_set():
            raise BusyError("the server is shutting down")
        if len(self._workers) >= self.max_running:
            running = ", ".join(self._workers)
            raise BusyError(
                f"the dashboard runs {len(self._workers)} benchmark(s) already ({running}), "
                f"the most it runs at once is {self.max_running}: cancel it or wait"
            )

    def _start(self, bench_id: str, workers: int) -> None:
        receive, send = self._ctx.Pipe(duplex=False)
        process = supervise.spawn(
            bench_worker.main,
            self.database,
            bench_id,
            workers,
            send,
            name=f"bench-{bench_id}",
            daemon=False,  # it starts processes of its own (the trials)
            what=f"benchmark {bench_id}",
            grace_s=bench_worker.STOP_GRACE_S,
        )
        send.close()
        self._workers[bench_id] = _Worker(bench_id, process, receive)

    # --- the watcher thread --------------------------------------------------------------------

    def _watch(self) -> None:
        swept = 0.0
        while True:
            with self._lock:
                workers = list(self._workers.values())
            for worker in workers:
                self._check(worker)
            if self._closing.is_set() and not workers:
                return
            now = time.monotonic()
            if now - swept >= self.sweep_s and not self._closing.is_set():
                swept = now
                try:
                    with self._lock:
                        mine = set(self._workers)
                    if self.store.settle_benches(skip=mine):
                        log.warning("benchmark(s) whose process died are now interrupted")
                except Exception:
                    log.exception("could not check for benchmarks whose process died")
            time.sleep(0.2)

    def _check(self, worker: _Worker) -> None:
        try:
            if worker.conn.poll():
                worker.outcome = worker.conn.recv()
        except (EOFError, OSError):
            pass
        if worker.process.is_alive():
            late = worker.stop_at is not None and (
                time.monotonic() - worker.stop_at > self.cancel_grace_s
            )
            if late:
                log.warning("benchmark %s did not stop; killing its worker", worker.bench_id)
                worker.process.kill()
            return
        worker.process.join(timeout=1.0)
        self._ended(worker, None)

    def _ended(self, worker: _Worker, reason: str | None) -> None:
        bench_id = worker.bench_id
        with self._lock:
            if worker.ended or self._workers.get(bench_id) is not worker:
                return
            worker.ended = True
        # The worker stays listed until its ending is in the store: a reader in between would
        # otherwise see the "interrupted" its process wrote on exit, not the "cancelled" below.
        kind, message = worker.outcome or ("died", None)
        try:
            status = self.store.get_bench(bench_id).status
            if worker.cancel_at is not None:
                status = "cancelled"
                message = "cancelled by the user; its finished trials are kept"
            elif worker.stop_at is not None:
                status = "interrupted"
                message = reason or "the server shut down; its finished trials are kept"
            elif kind == "error":
                status = "interrupted"
            elif kind == "died":
                status = "interrupted"
                message = reason or f"its worker process died (exit code {worker.process.exitcode})"
            elif status == "running":  # the worker said done, yet did not record it
                status = "interrupted"
            self.store.set_bench_status(bench_id, status)
        except Exception:
            log.exception("benchmark %s: could not record how it ended", bench_id)
        with self._lock:
            if message:
                self._messages[bench_id] = message
            self._workers.pop(bench_id, None)
        worker.conn.close()
        log.info("benchmark %s ended: %s %s", bench_id, kind, message or "")
