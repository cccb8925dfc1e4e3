"""What runs in a training job's process: the code of ``tamp train`` on the chosen runs of the
dashboard's store, the model file written under the job's name. Its messages: ``("progress",
(fraction, stream))`` as training goes, then ``("done", report)`` or ``("error", message)``."""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from multiprocessing.connection import Connection
from typing import Any

log = logging.getLogger(__name__)

PROGRESS_S = 0.25  # at most this often a progress message


def main(spec: dict[str, Any], database: str, out: str, conn: Connection) -> None:
    """Entry point of a training process."""
    logging.basicConfig(
        level=logging.WARNING, format="%(asctime)s %(levelname)s train %(name)s: %(message)s"
    )
    lock = threading.Lock()

    def send(message: tuple[str, Any]) -> None:
        with lock, contextlib.suppress(OSError):
            conn.send(message)

    try:
        from planner.learning.train import TrainProgress, load_records, records_domain, train

        records = load_records([database], domain=spec["domain"], run_ids=spec["runs"])
        if not records:
            raise ValueError(f"no stream queries of domain {spec['domain']!r} in these runs")
        loaded = records_domain(records)
        last = 0.0

        def progress(p: TrainProgress) -> None:
            nonlocal last
            now = time.monotonic()
            if now - last >= PROGRESS_S or p.epoch == 0:
                last = now
                send(("progress", (p.fraction, p.stream)))

        model, report = train(
            records,
            domain=loaded,
            seed=int(spec["seed"]),
            epochs=int(spec["epochs"]),
            metadata={"provenance": spec["provenance"]},
            progress=progress,
        )
        model.save(out)
        send(("done", report.to_dict()))
    except Exception as exc:
        log.exception("training %s failed", spec["name"])
        send(("error", f"{type(exc).__name__}: {exc}"))
    finally:
        with contextlib.suppress(OSError):
            conn.close()
