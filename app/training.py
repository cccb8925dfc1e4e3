"""Training cost models from runs stored in the dashboard: one job at a time, in a process of
its own, with the code of ``tamp train`` (``planner.learning.train.load_records`` and
``train``), its progress reported as it goes.

A job is checked before it starts, and refused with the reason: runs that do not exist or are
still going, runs of more than one domain (a model is for one domain), too few queries for any
stream to get a network, fewer than two runs (one is held out for validation), a name that is
taken. While a job runs, another is refused (:class:`~app.errors.BusyError`, a 429). The model
file is written into the dashboard's model folder under the job's name, with its provenance
(the runs, the benchmark they came from, when, by whom) next to what ``train`` records (the
seeds per scene, which benchmarks then refuse to test on, and the validation figures), and is
offered by name at once (``GET /api/models``).
"""

from __future__ import annotations

import logging
import threading
import time
import uuid
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from typing import Any

from app import catalog, train_worker
from app.errors import BusyError, RequestError
from planner import supervise
from planner.domains import domain_of_scene, find_scene, load_domain
from planner.scene import SceneError
from planner.store import LIVE_STATUSES, RunStore

log = logging.getLogger(__name__)

MIN_QUERIES = 30  # a stream needs this many queries for a network (train's min_queries)
MIN_RUNS = 2  # one run at least is held out for validation
KEPT_JOBS = 50  # finished jobs listed


@dataclass(frozen=True)
class TrainJob:
    id: str
    name: str  # the model's name, once trained
    domain: str
    runs: tuple[str, ...]
    queries: int
    seed: int
    epochs: int
    status: str  # running, done, failed
    created_at: datetime
    finished_at: datetime | None = None
    progress: float = 0.0  # 0 to 1
    stream: str | None = None  # the stream being fitted
    message: str = ""
    report: dict[str, Any] | None = None  # the validation report (planner.learning.train)
    benchmark: str | None = None  # where the runs came from, if the page said


@dataclass
class _Running:
    job_id: str
    process: BaseProcess
    conn: Connection
    started: float = field(default_factory=time.monotonic)


class TrainingService:
    def __init__(
        self,
        store: RunStore,
        database: str,
        domains: catalog.Domains,
        models: catalog.Models,
    ) -> None:
        self.store = store
        self.database = database
        self.domains = domains
        self.models = models
        self._ctx = supervise.context()
        self._lock = threading.RLock()
        self._jobs: dict[str, TrainJob] = {}
        self._running: _Running | None = None
        self._closing = threading.Event()
        self._thread = threading.Thread(target=self._watch, name="training", daemon=True)
        self._thread.start()
        self._domain_cache: dict[tuple[str, str | None], str] = {}

    # --- reading -------------------------------------------------------------------------------

    def list(self) -> list[TrainJob]:
        """Newest first."""
        with self._lock:
            return sorted(self._jobs.values(), key=lambda j: j.created_at, reverse=True)

    def get(self, job_id: str) -> TrainJob:
        """KeyError for an unknown job."""
        with self._lock:
            if job_id not in self._jobs:
                raise KeyError(f"unknown training job {job_id!r}")
            return self._jobs[job_id]

    # --- submitting ------------------------------------------------------------------------------

    def submit(
        self,
        *,
        name: str,
        runs: Sequence[str],
        seed: int,
        epochs: int,
        benchmark: str | None = None,
    ) -> TrainJob:
        """Check and start a job; :class:`RequestError` names the field that is wrong,
        :class:`BusyError` while another job runs."""
        with self._lock:
            if self._running is not None:
                busy = self._jobs[self._running.job_id]
                raise BusyError(
                    f"training job {busy.id} ({busy.name}) is running; the dashboard trains one "
                    "model at a time: wait for it, then submit again"
                )
            if self._closing.is_set():
                raise BusyError("the server is shutting down")
        if not catalog.safe_name(name):
            raise RequestError("name", f"{name!r} is not a model name")
        if self.models.exists(name):
            raise RequestError("name", f"a model named {name!r} exists: choose another name")
        if benchmark is not None:
            try:
                self.store.get_bench(benchmark)
            except KeyError as exc:
                raise RequestError("benchmark", str(exc.args[0])) from exc
        domain = self._check_runs(runs)
        queries = self._check_queries(runs)
        job = TrainJob(
            id=uuid.uuid4().hex[:12],
            name=name,
            domain=domain,
            runs=tuple(runs),
            queries=queries,
            seed=seed,
            epochs=epochs,
            status="running",
            created_at=datetime.now(UTC),
            benchmark=benchmark,
        )
        spec = {
            "name": name,
            "domain": domain,
            "runs": list(runs),
            "seed": seed,
            "epochs": epochs,
            "provenance": {
                "trained_by": "dashboard",
                "job": job.id,
                "runs": list(runs),
                "benchmark": benchmark,
                "store": self.store.backend,
                "requested_at": job.created_at.isoformat(timespec="seconds"),
            },
        }
        with self._lock:
            if self._running is not None:  # another request got here first
                raise BusyError("a training job is running; the dashboard trains one at a time")
            receive, send = self._ctx.Pipe(duplex=False)
            out = self.models.directory / f"{name}.pt"
            process = supervise.spawn(
                train_worker.main,
                spec,
                self.database,
                str(out),
                send,
                name=f"train-{job.id}",
                what=f"training {name}",
            )
            send.close()
            self._running = _Running(job.id, process, receive)
            self._jobs[job.id] = job
            self._forget_old()
        log.info("training job %s: model %s from %d runs of %s", job.id, name, len(runs), domain)
        return job

    def _check_runs(self, runs: Sequence[str]) -> str:
        """The one domain of the runs; RequestError names the run that does not fit."""
        if len(set(runs)) != len(runs):
            dup = next(i for i, r in enumerate(runs) if runs.index(r) != i)
            raise RequestError(["runs", dup], f"run {runs[dup]!r} is listed twice")
        if len(runs) < MIN_RUNS:
            raise RequestError(
                "runs",
                f"{len(runs)} run(s): training needs at least {MIN_RUNS}, one being held out "
                "to validate the model on",
            )
        domains: dict[str, list[int]] = {}
        for i, run_id in enumerate(runs):
            try:
                record = self.store.get_run(run_id)
            except KeyError as exc:
                raise RequestError(["runs", i], f"unknown run {run_id!r}") from exc
            if record.status in LIVE_STATUSES:
                raise RequestError(["runs", i], f"run {run_id} is still {record.status}")
            ref = record.config.get("domain")
            domain = self._domain(record.scene, ref if isinstance(ref, str) else None)
            if domain is None:
                raise RequestError(
                    ["runs", i], f"run {run_id}: its scene {record.scene!r} no longer loads"
                )
            domains.setdefault(domain, []).append(i)
        if len(domains) > 1:
            first, *others = sorted(domains, key=lambda d: (-len(domains[d]), d))
            odd = domains[others[0]][0]
            counts = ", ".join(f"{d} ({len(ix)} runs)" for d, ix in domains.items())
            raise RequestError(
                ["runs", odd],
                f"the runs are of several domains ({counts}); a model is for one domain: run "
                f"{runs[odd]} is of {others[0]!r}, most are of {first!r}",
            )
        return next(iter(domains))

    def _check_queries(self, runs: Sequence[str]) -> int:
        per_stream: dict[str, int] = {}
        outcomes = self.store.query_outcomes(list(runs))
        for q in outcomes:
            per_stream[q.stream] = per_stream.get(q.stream, 0) + 1
        most = max(per_stream.values(), default=0)
        if most < MIN_QUERIES:
            shown = ", ".join(f"{s} {n}" for s, n in sorted(per_stream.items())) or "none"
            raise RequestError(
                "runs",
                f"too few stream queries to train on: {len(outcomes)} in these runs ({shown}); "
                f"a stream needs {MIN_QUERIES} for a network: add runs",
            )
        return len(outcomes)

    def _domain(self, scene: str, ref: str | None) -> str | None:
        key = (scene, ref)
        if key not in self._domain_cache:
            try:
                given = load_domain(ref) if ref is not None else None
                found = domain_of_scene(find_scene(scene, domain=given), given)
                self._domain_cache[key] = found.name
            except (SceneError, ValueError, OSError) as exc:
                log.info("scene %s (domain %s) does not load: %s", scene, ref, exc)
                return None
        return self._domain_cache[key]

    # --- the job's process ----------------------------------------------------------------------

    def _watch(self) -> None:
        while not self._closing.is_set():
            with self._lock:
                running = self._running
            if running is None:
                time.sleep(0.2)
                continue
            try:
                ready = running.conn.poll(0.2)
                message = running.conn.recv() if ready else None
            except (EOFError, OSError):
                message = ("died", None)
            if message is not None:
                self._on(running, message)
            elif not running.process.is_alive():
                running.process.join(timeout=1.0)
                self._finish(
                    running,
                    status="failed",
                    message=f"the training process died (exit code {running.process.exitcode})",
                )

    def _on(self, running: _Running, message: tuple[str, Any]) -> None:
        kind, payload = message
        if kind == "progress":
            fraction, stream = payload
            self._update(running.job_id, progress=float(fraction), stream=str(stream))
        elif kind == "done":
            self._finish(running, status="done", report=payload, message="trained")
        elif kind == "error":
            self._finish(running, status="failed", message=str(payload))
        else:
            died = f"the training process died (exit code {running.process.exitcode})"
            self._finish(running, status="failed", message=died)

    def _update(self, job_id: str, **changes: Any) -> None:
        with self._lock:
            self._jobs[job_id] = replace(self._jobs[job_id], **changes)

    def _finish(
        self,
        running: _Running,
        *,
        status: str,
        message: str,
        report: dict[str, Any] | None = None,
    ) -> None:
        running.process.join(timeout=5.0)
        running.conn.close()
        changes: dict[str, Any] = {
            "status": status,
            "message": message,
            "finished_at": datetime.now(UTC),
            "report": report,
        }
        if status == "done":
            changes["progress"] = 1.0
        with self._lock:
            self._update(running.job_id, **changes)
            self._running = None
        log.info("training job %s: %s (%s)", running.job_id, status, message)

    def _forget_old(self) -> None:
        done = [j for j in self.list() if j.status != "running"]
        for job in done[KEPT_JOBS:]:
            del self._jobs[job.id]

    def close(self) -> None:
        self._closing.set()
        with self._lock:
            running = self._running
        if running is not None and running.process.is_alive():
            running.process.terminate()
            running.process.join(timeout=5.0)
        self._thread.join(timeout=2.0)
