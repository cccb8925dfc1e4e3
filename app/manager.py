"""The run manager: runs execute in worker processes, at most ``max_running`` at once, the rest
queued in order.

Planning is CPU-bound, so each run gets its own (spawned) process and the server stays
responsive. A worker records its run in the store itself and sends each batch of events through
a pipe once it is stored; one reader thread here receives them and hands them to the
:class:`~app.hub.EventHub`. A worker that dies without saying it is done (killed, crashed) has
its run finished here (:meth:`~planner.store.RunStore.settle_run`: a closing event it stored
decides, else the run is failed, or cancelled when the user asked, with a closing event).
Cancelling asks the worker to stop (the search checks between iterations) and kills it after
``cancel_grace_s``. When the server shuts down (SIGTERM, Ctrl-C) its live runs are stopped the
same way and recorded as stopped by the shutdown (:data:`app.worker.SERVER_SHUT_DOWN`), not
as cancelled by a user. Every ``sweep_s`` the reader also finishes runs of other processes that
died (an earlier server's workers, a killed ``tamp plan``).
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from dataclasses import asdict, dataclass, field
from multiprocessing.connection import Connection, wait
from multiprocessing.process import BaseProcess
from multiprocessing.synchronize import Event as MpEvent
from typing import Any

from app import worker as worker_module
from app.hub import EventHub
from app.worker import SERVER_SHUT_DOWN
from planner import supervise
from planner.api import CANCELLED_BY_USER
from planner.events import event_to_dict
from planner.runs import RunConfig
from planner.store import RunStore

log = logging.getLogger(__name__)


class QueueFullError(Exception):
    """More launches than the queue holds."""


class RunNotLiveError(Exception):
    """Cancelling a run that is already finished."""


@dataclass
class _Worker:
    run_id: str
    process: BaseProcess
    conn: Connection
    stop: MpEvent
    started: float = field(default_factory=time.monotonic)
    cancel_at: float | None = None  # monotonic time the user (or the shutdown) asked to stop
    shutdown: bool = False  # asked to stop because the server shuts down, not by a user
    done: bool = False  # the worker said it finished
    ending: bool = False  # its run is being finished here


class RunManager:
    def __init__(
        self,
        store: RunStore,
        database: str,
        hub: EventHub,
        *,
        max_running: int = 1,
        max_queued: int = 20,
        cancel_grace_s: float = 10.0,
        sweep_s: float = 2.0,
    ) -> None:
        self.store = store
        self.database = database
        self.hub = hub
        self.max_running = max_running
        self.max_queued = max_queued
        self.cancel_grace_s = cancel_grace_s
        self.sweep_s = sweep_s
        self._swept = time.monotonic()
        self._ctx = supervise.context()
        self._shutdown = self._ctx.Event()  # set when the server shuts down: every worker sees it
        self._lock = threading.RLock()
        self._pending: deque[tuple[str, RunConfig]] = deque()
        self._workers: dict[str, _Worker] = {}
        self._closing = False
        self._reader = threading.Thread(target=self._read, name="run-manager", daemon=True)
        self._reader.start()

    # --- what the API calls -------------------------------------------------------------------

    def counts(self) -> tuple[int, int]:
        """(running, queued)."""
        with self._lock:
            return len(self._workers), len(self._pending)

    def submit(self, config: RunConfig, shown: dict[str, Any] | None = None) -> str:
        """Queue a run (recorded as ``queued`` at once, with its configuration and ``shown``,
        what the page shows of it besides: a model's name); returns its id. The worker gets
        ``config`` itself."""
        with self._lock:
            if self._closing:
                raise QueueFullError("the server is shutting down")
            free = self.max_running - len(self._workers)
            if free <= 0 and len(self._pending) >= self.max_queued:
                raise QueueFullError(
                    f"{len(self._workers)} runs are running and {len(self._pending)} are queued "
                    f"(the most this server queues is {self.max_queued}); try again when one "
                    "finishes, or cancel one"
                )
            run_id = self.store.create_run(
                config.scene,
                config.seed,
                config.planner,
                {**asdict(config), **(shown or {})},
                status="queued",
            )
            self.hub.open(run_id)
            self._pending.append((run_id, config))
            self._dispatch()
        log.info(
            "run %s queued (%s, seed %d, %s)", run_id, config.scene, config.seed, config.planner
        )
        return run_id

    def cancel(self, run_id: str) -> None:
        """Cancel a queued or running run; :class:`RunNotLiveError` if it is over."""
        with self._lock:
            for i, (queued_id, _) in enumerate(self._pending):
                if queued_id == run_id:
                    del self._pending[i]
                    self._settle(run_id, "cancelled", "cancelled before it started")
                    return
            worker = self._workers.get(run_id)
            if worker is None:
                status = self.store.get_run(run_id).status  # KeyError for an unknown run
                raise RunNotLiveError(f"run {run_id} is already over ({status})")
            if worker.cancel_at is None:
                worker.cancel_at = time.monotonic()
                worker.stop.set()
                log.info("run %s: cancel requested", run_id)

    def close(self, timeout_s: float = 5.0) -> None:
        """Stop everything: queued runs are cancelled, running ones asked to stop then killed."""
        with self._lock:
            self._closing = True
            self._shutdown.set()  # before any stop: a worker that stops reads why
            while self._pending:
                run_id, _ = self._pending.popleft()
                self._settle(run_id, "cancelled", "the server shut down before it started")
            for worker in self._workers.values():
                worker.stop.set()
                if worker.cancel_at is None:
                    worker.cancel_at = time.monotonic()
                    worker.shutdown = True
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with self._lock:
                if not self._workers:
                    break
            time.sleep(0.05)
        with self._lock:
            for worker in list(self._workers.values()):
                self._kill(worker, f"{SERVER_SHUT_DOWN} (stopped by force)")
        self._reader.join(timeout=2.0)

    # --- workers ------------------------------------------------------------------------------

    def _dispatch(self) -> None:
        with self._lock:
            while self._pending and len(self._workers) < self.max_running and not self._closing:
                run_id, config = self._pending.popleft()
                self.store.start_run(run_id)
                receive, send = self._ctx.Pipe(duplex=False)
                stop = self._ctx.Event()
                process = supervise.spawn(
                    worker_module.main,
                    run_id,
                    config,
                    self.database,
                    send,
                    stop,
                    self._shutdown,
                    name=f"run-{run_id[:8]}",
                    what=f"run {run_id}",
                )
                send.close()  # the worker holds the other end; EOF here means it is gone
                self._workers[run_id] = _Worker(run_id, process, receive, stop)
                log.info("run %s started in process %s", run_id, process.pid)

    def _read(self) -> None:
        while True:
            with self._lock:
                if self._closing and not self._workers:
                    return
                conns = {w.conn: w for w in self._workers.values() if not w.ending}
            if not conns:
                time.sleep(0.05)
                self._sweep()
                continue
            for conn in wait(list(conns), timeout=0.2):
                worker = conns[conn]  # type: ignore[index]
                try:
                    kind, run_id, payload = worker.conn.recv()
                except (EOFError, OSError):
                    self._ended(worker)
                    continue
                except Exception:
                    log.exception("run %s: unreadable message from its worker", worker.run_id)
                    continue
                if kind == "events":
                    self.hub.publish(run_id, payload)
                elif kind == "done":
                    worker.done = True
            self._check_cancels()
            self._sweep()

    def _sweep(self) -> None:
        """Finish the runs of other processes that died (never one of this server's)."""
        now = time.monotonic()
        if now - self._swept < self.sweep_s:
            return
        self._swept = now
        with self._lock:
            if self._closing:
                return
            mine = set(self._workers) | {run_id for run_id, _ in self._pending}
        try:
            settled = self.store.mark_interrupted(skip=mine)
        except Exception:
            log.exception("could not check for runs whose process died")
            return
        if settled:
            log.warning("%d run(s) whose process died are now finished", settled)

    def _check_cancels(self) -> None:
        now = time.monotonic()
        with self._lock:
            late = [
                w
                for w in self._workers.values()
                if w.cancel_at is not None and now - w.cancel_at > self.cancel_grace_s
            ]
        for worker in late:
            log.warning(
                "run %s did not stop within %.0f s; killing it", worker.run_id, self.cancel_grace_s
            )
            reason = SERVER_SHUT_DOWN if worker.shutdown else CANCELLED_BY_USER
            self._kill(worker, f"{reason} (stopped by force)")

    def _kill(self, worker: _Worker, reason: str) -> None:
        if worker.process.is_alive():
            worker.process.terminate()
            worker.process.join(timeout=2.0)
            if worker.process.is_alive():
                worker.process.kill()
        self._ended(worker, reason=reason)

    def _ended(self, worker: _Worker, *, reason: str | None = None) -> None:
        with self._lock:
            if worker.ending or worker.run_id not in self._workers:
                return
            worker.ending = True  # stays in _workers until its run is finished: _sweep skips it
        worker.process.join(timeout=5.0)
        worker.conn.close()
        run_id = worker.run_id
        cancelled = worker.cancel_at is not None
        if reason is not None:
            message = reason
        elif worker.shutdown:  # it ended (stopped, or killed by whoever stops the server)
            message = SERVER_SHUT_DOWN
        elif cancelled:
            message = CANCELLED_BY_USER
        elif worker.done:  # it said it was done, yet the run is not finished: see its log
            message = "the worker stopped without finishing the run (the server log says why)"
        else:
            message = f"the worker process died (exit code {worker.process.exitcode})"
        status = self._settle(run_id, "cancelled" if cancelled else "failed", message)
        with self._lock:
            self._workers.pop(run_id, None)
        log.info("run %s ended: %s", run_id, status)
        self._dispatch()

    def _settle(self, run_id: str, status: str, message: str) -> str:
        """Finish a run its worker did not (a closing event it stored decides), send the
        clients what they have not had, and end it in the hub; returns its final status."""
        try:
            if self.store.settle_run(run_id, status, message) is None:
                log.debug("run %s was finished by its worker", run_id)
            status = self.store.get_run(run_id).status
            seen = self.hub.events(run_id) or []
            stored = self.store.events(run_id, after=seen[-1]["seq"] if seen else -1)
            self.hub.publish(run_id, [event_to_dict(e) for e in stored])
        except Exception:
            log.exception("run %s: could not record how it ended", run_id)
            status = "failed"
        self.hub.end(run_id, status)
        return status
