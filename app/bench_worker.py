"""What runs in a benchmark's worker process: ``planner.bench.run_bench`` resuming a benchmark
the server recorded (``tamp bench --resume``, the same code), its trials in processes of their
own.

SIGTERM (a cancel from the page) stops it the way Ctrl-C stops ``tamp bench``: the running
trials are stopped, the benchmark is left ``interrupted`` with every finished trial kept, and
the server then marks it ``cancelled``. A worker whose server goes away stops the same way.
Its last message says how it ended: ``("done", None)`` or ``("error", message)``.
"""

from __future__ import annotations

import contextlib
import logging
import signal
from multiprocessing.connection import Connection

log = logging.getLogger(__name__)

STOP_GRACE_S = 30.0  # a worker whose server is gone is ended this long after SIGTERM


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def main(database: str, bench_id: str, workers: int, conn: Connection) -> None:
    """Entry point of a benchmark worker process."""
    logging.basicConfig(
        level=logging.WARNING, format="%(asctime)s %(levelname)s bench %(name)s: %(message)s"
    )
    signal.signal(signal.SIGTERM, _interrupt)
    from planner.bench import BenchError, run_bench

    outcome: tuple[str, str | None] = ("done", None)
    try:
        run_bench(database, resume=bench_id, workers=workers)
    except KeyboardInterrupt:
        log.warning("benchmark %s stopped; its finished trials are kept", bench_id)
        outcome = ("stopped", None)
    except BenchError as exc:
        outcome = ("error", str(exc))
    except Exception as exc:
        log.exception("benchmark %s failed", bench_id)
        outcome = ("error", f"{type(exc).__name__}: {exc}")
    with contextlib.suppress(OSError):
        conn.send(outcome)
        conn.close()
