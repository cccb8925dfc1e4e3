"""What runs in a run's worker process: one recorded run, its events sent to the server.

The worker writes its events to the store itself (:func:`planner.runs.record_run`) and sends
them, in small batches, through a pipe to the server, which fans them out to websocket clients
and the 3D view. Its last message is ``("done", run_id, None)``, sent after the store holds
every event; a worker that dies without it is handled by the run manager.
"""

from __future__ import annotations

import contextlib
import logging
import threading
from multiprocessing.connection import Connection
from multiprocessing.synchronize import Event as MpEvent
from typing import Any

from planner.events import BatchingSink, Event, event_to_dict

log = logging.getLogger(__name__)


class PipeSink(BatchingSink):
    """Sends batches of event dicts through a pipe (every 0.1 s at the latest)."""

    def __init__(self, run_id: str, conn: Connection, lock: threading.Lock) -> None:
        self.run_id = run_id
        self.conn = conn
        self.lock = lock
        super().__init__(
            self._send, name=f"pipe-sink-{run_id[:8]}", batch_size=100, flush_interval_s=0.1
        )

    def __repr__(self) -> str:
        return f"PipeSink(run_id={self.run_id!r})"

    def _send(self, batch: list[Event]) -> None:
        message = ("events", self.run_id, [event_to_dict(e) for e in batch])
        with self.lock:
            self.conn.send(message)


def main(
    run_id: str, config: dict[str, Any], database: str, conn: Connection, stop: MpEvent
) -> None:
    """Entry point of a worker process."""
    logging.basicConfig(
        level=logging.WARNING, format="%(asctime)s %(levelname)s worker %(name)s: %(message)s"
    )
    from planner.runs import RunConfig, preload_libraries, record_run
    from planner.store import RunStore

    lock = threading.Lock()
    store = RunStore(database)
    sink = PipeSink(run_id, conn, lock)
    try:
        run_config = RunConfig(**config)
        preload_libraries(run_config)
        record_run(run_config, store, run_id, sinks=(sink,), should_stop=stop.is_set)
    except KeyboardInterrupt:
        log.warning("run %s interrupted", run_id)
    except Exception:
        log.exception("run %s failed", run_id)  # already finished as failed in the store
    finally:
        sink.close()
        store.close()
        with lock:
            with contextlib.suppress(OSError):
                conn.send(("done", run_id, None))
            conn.close()
