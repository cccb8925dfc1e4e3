"""What runs in a run's worker process: one recorded run, its stored events sent to the server.

The worker takes the run over in the store (:meth:`~planner.store.RunStore.claim_run`), records
it (:func:`planner.runs.record_run`) and, each time a batch of events has been committed,
sends that batch through a pipe to the server, which fans it out to websocket clients and the
3D view. So the server only ever serves events the store holds: a crash can lose only events
no client has seen. Its last message is ``("done", run_id, None)``, sent after the run is
finished in the store; a worker that dies without it is handled by the run manager.

A worker never outlives its server: it is started by :func:`planner.supervise.spawn`, which
ends it at once when the server goes away (killed, crashed). The run is then finished by the
next server that opens the store (:meth:`~planner.store.RunStore.mark_interrupted`).
"""

from __future__ import annotations

import contextlib
import logging
import threading
from multiprocessing.connection import Connection
from multiprocessing.synchronize import Event as MpEvent
from typing import TYPE_CHECKING, Any

from planner.events import Event, event_to_dict

if TYPE_CHECKING:
    from planner.api import RunConfig

log = logging.getLogger(__name__)

# Why a run was stopped when its server shut down (SIGTERM, Ctrl-C of tamp serve) while it ran:
# the closing run_cancelled event's reason and the run's message. Not "by the user": nobody
# cancelled this run.
SERVER_SHUT_DOWN = "stopped: the server shut down while it ran"


class _Pipe:
    """The server's end of the conversation; a gone server is not this run's error."""

    def __init__(self, conn: Connection) -> None:
        self.conn = conn
        self.lock = threading.Lock()

    def send(self, message: tuple[str, str, Any]) -> None:
        with self.lock, contextlib.suppress(OSError):
            self.conn.send(message)

    def stored(self, run_id: str, events: list[Event]) -> None:
        """A write listener of the store: the batch is committed, the server may serve it."""
        self.send(("events", run_id, [event_to_dict(e) for e in events]))

    def close(self) -> None:
        with self.lock:
            self.conn.close()


def main(
    run_id: str,
    config: RunConfig,
    database: str,
    conn: Connection,
    stop: MpEvent,
    shutdown: MpEvent | None = None,
) -> None:
    """Entry point of a worker process. ``stop`` set: stop the run; ``shutdown`` set too: it
    is stopped because the server shuts down (:data:`SERVER_SHUT_DOWN`), else the user
    cancelled it."""
    logging.basicConfig(
        level=logging.WARNING, format="%(asctime)s %(levelname)s worker %(name)s: %(message)s"
    )
    from planner.api import CANCELLED_BY_USER
    from planner.runs import preload_libraries, record_run
    from planner.store import RunStore

    def why_stopped() -> str:
        return SERVER_SHUT_DOWN if shutdown is not None and shutdown.is_set() else CANCELLED_BY_USER

    pipe = _Pipe(conn)
    store = RunStore(database)
    store.add_write_listener(pipe.stored)
    try:
        if not store.claim_run(run_id):
            log.warning("run %s is no longer running; not started", run_id)
            return
        preload_libraries(config)
        record_run(config, store, run_id, should_stop=stop.is_set, stop_reason=why_stopped)
    except KeyboardInterrupt:
        log.warning("run %s interrupted", run_id)
    except Exception:
        log.exception("run %s failed", run_id)  # already finished as failed in the store
    finally:
        store.close()
        pipe.send(("done", run_id, None))
        pipe.close()
