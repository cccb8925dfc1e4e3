"""Which run and step the 3D view shows; live events of the followed run reach it.

All calls into the viewer happen on one thread of this module, in order, so a slow redraw never
holds up a request or the run manager's reader thread.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable
from typing import Any, Protocol

from app.hub import EventDict, EventHub
from planner.events import event_to_dict
from planner.store import RunStore

log = logging.getLogger(__name__)


class Viewer(Protocol):
    @property
    def url(self) -> str: ...

    def show(
        self,
        scene: str,
        seed: int,
        events: Any,
        plan: dict[str, Any] | None,
        *,
        domain: str | None = None,
        focus: int | None = None,
        run_id: str | None = None,
    ) -> None: ...

    def extend(self, events: Any) -> None: ...

    @property
    def picked(self) -> Any: ...

    def close(self) -> None: ...


class ViewerService:
    def __init__(self, viewer: Viewer | None, store: RunStore, hub: EventHub) -> None:
        self.viewer = viewer
        self.store = store
        self.hub = hub
        self.following: str | None = None  # run whose live events reach the view
        self.shown: tuple[str, int | None, int | None] | None = None  # (run, step, node) asked
        self._last_seq = -1  # the last event the view has (viewer thread only)
        self._jobs: queue.Queue[Callable[[], None] | None] = queue.Queue()
        self._thread = threading.Thread(target=self._work, name="viewer", daemon=True)
        if viewer is not None:
            self._thread.start()
            hub.add_listener(self._on_events)
            hub.add_end_listener(self._on_end)

    @property
    def url(self) -> str | None:
        return None if self.viewer is None else self.viewer.url

    def follow(self, run_id: str, step: int | None, node: int | None = None) -> None:
        """Show ``run_id`` after events ``0..step`` (all of them and live ones when None), with
        search node ``node`` selected (None: none). KeyError for an unknown run."""
        record = self.store.get_run(run_id)
        self.shown = (run_id, step, node)
        if self.viewer is None:
            return
        self.following = run_id if step is None else None

        def job() -> None:
            events = self._events(run_id, step)
            assert self.viewer is not None
            plan = self.store.get_run(run_id).plan
            self._last_seq = events[-1]["seq"] if events else -1
            ref = record.config.get("domain")
            domain = ref if isinstance(ref, str) else None
            self.viewer.show(
                record.scene, record.seed, events, plan, domain=domain, focus=node, run_id=run_id
            )

        self._jobs.put(job)

    def close(self) -> None:
        if self.viewer is None:
            return
        self._jobs.put(None)
        self._thread.join(timeout=5.0)
        self.viewer.close()

    def _events(self, run_id: str, step: int | None) -> list[EventDict]:
        limit = None if step is None else step + 1
        events = [event_to_dict(e) for e in self.store.events(run_id, limit=limit)]
        if step is None or len(events) < step + 1:  # the rest may still be on its way
            last = events[-1]["seq"] if events else -1
            more = self.hub.events(run_id, after=last) or []
            if step is not None:
                more = [e for e in more if e["seq"] <= step]
            events += more
        return events

    def _on_events(self, run_id: str, events: list[EventDict]) -> None:
        if run_id != self.following or self.viewer is None:
            return
        viewer = self.viewer

        def job() -> None:
            if self.following != run_id:
                return
            fresh = [e for e in events if e["seq"] > self._last_seq]  # show() may have them
            if fresh:
                self._last_seq = fresh[-1]["seq"]
                viewer.extend(fresh)

        self._jobs.put(job)

    def _on_end(self, run_id: str, _status: str) -> None:
        """A followed run is over: show it whole, with its plan to animate when it has one."""
        if run_id == self.following:
            node = self.shown[2] if self.shown is not None and self.shown[0] == run_id else None
            self.follow(run_id, None, node)

    def picked(self) -> Any:
        """The ghost last clicked in the 3D view (its node), if any."""
        return None if self.viewer is None else self.viewer.picked

    def _work(self) -> None:
        while True:
            job = self._jobs.get()
            if job is None:
                return
            try:
                job()
            except Exception:
                log.exception("the 3D view failed to update")
