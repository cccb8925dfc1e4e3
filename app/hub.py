"""Live events of queued and running runs, fanned out to websocket clients.

The run manager's reader thread :meth:`EventHub.publish`\\ es batches of event dicts; each
websocket client holds a :class:`Subscription` whose asyncio queue is bounded in events. A client
that falls further behind than that is marked lagged: its queue is emptied and it is told to
resynchronise from the store, so a slow or vanished client never holds the planner or the other
clients back. Only stored events reach the hub: a worker sends a batch once the store has
committed it, and the run manager publishes the closing events it writes after writing them, so
nothing a client is sent can be lost by a crash. The hub keeps every event of a live run until
the run ends.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

log = logging.getLogger(__name__)

EventDict = dict[str, Any]


@dataclass(frozen=True)
class Lagged:
    """The subscriber fell behind; its queue was dropped."""


@dataclass(frozen=True)
class Ended:
    status: str


Item = list[EventDict] | Lagged | Ended


class Subscription:
    """One client's view of one live run (used on the event loop only)."""

    def __init__(self, run_id: str, limit: int) -> None:
        self.run_id = run_id
        self.limit = limit
        self.queue: asyncio.Queue[Item] = asyncio.Queue()
        self.pending = 0  # events queued
        self.lagged = False

    def offer(self, batch: list[EventDict]) -> None:
        if self.lagged:
            return
        if self.pending + len(batch) > self.limit:
            self.lagged = True
            while not self.queue.empty():
                self.queue.get_nowait()
            self.pending = 0
            self.queue.put_nowait(Lagged())
            return
        self.pending += len(batch)
        self.queue.put_nowait(batch)

    def end(self, status: str) -> None:
        self.queue.put_nowait(Ended(status))

    async def get(self) -> Item:
        item = await self.queue.get()
        if isinstance(item, list):
            self.pending -= len(item)
        return item


@dataclass
class _Live:
    events: list[EventDict] = field(default_factory=list)
    subscribers: dict[Subscription, asyncio.AbstractEventLoop] = field(default_factory=dict)


class EventHub:
    """Thread-safe: publish from any thread; subscriptions live on their event loop."""

    def __init__(self, client_limit: int = 5000) -> None:
        self.client_limit = client_limit
        self._lock = threading.Lock()
        self._live: dict[str, _Live] = {}
        self._listeners: list[Callable[[str, list[EventDict]], None]] = []
        self._end_listeners: list[Callable[[str, str], None]] = []

    def add_listener(self, listener: Callable[[str, list[EventDict]], None]) -> None:
        """``listener(run_id, events)`` is called in the publishing thread for every batch."""
        self._listeners.append(listener)

    def add_end_listener(self, listener: Callable[[str, str], None]) -> None:
        """``listener(run_id, status)`` is called when a run ends (the store has all of it)."""
        self._end_listeners.append(listener)

    def open(self, run_id: str) -> None:
        with self._lock:
            self._live.setdefault(run_id, _Live())

    def is_live(self, run_id: str) -> bool:
        with self._lock:
            return run_id in self._live

    def publish(self, run_id: str, events: list[EventDict]) -> None:
        if not events:
            return
        with self._lock:
            live = self._live.get(run_id)
            if live is None:
                log.warning("events for run %s, which is not live; dropped", run_id)
                return
            live.events.extend(events)
            subscribers = list(live.subscribers.items())
        for sub, loop in subscribers:
            _call(loop, sub.offer, events)
        for listener in self._listeners:
            try:
                listener(run_id, events)
            except Exception:
                log.exception("event listener %r failed", listener)

    def end(self, run_id: str, status: str) -> None:
        with self._lock:
            live = self._live.pop(run_id, None)
        if live is None:
            return
        for sub, loop in live.subscribers.items():
            _call(loop, sub.end, status)
        for listener in self._end_listeners:
            try:
                listener(run_id, status)
            except Exception:
                log.exception("end listener %r failed", listener)

    def events(self, run_id: str, after: int = -1) -> list[EventDict] | None:
        """The live run's events with ``seq > after``; None when the run is not live."""
        with self._lock:
            live = self._live.get(run_id)
            if live is None:
                return None
            return [e for e in live.events if e["seq"] > after]

    def subscribe(
        self, run_id: str, after: int = -1
    ) -> tuple[list[EventDict], Subscription] | None:
        """Events so far (``seq > after``) and a subscription to the rest, atomically; None
        when the run is not live. Call on the event loop the subscription will be read on."""
        loop = asyncio.get_running_loop()
        with self._lock:
            live = self._live.get(run_id)
            if live is None:
                return None
            sub = Subscription(run_id, self.client_limit)
            live.subscribers[sub] = loop
            return [e for e in live.events if e["seq"] > after], sub

    def unsubscribe(self, sub: Subscription) -> None:
        with self._lock:
            live = self._live.get(sub.run_id)
            if live is not None:
                live.subscribers.pop(sub, None)

    def subscribers(self, run_id: str) -> int:
        with self._lock:
            live = self._live.get(run_id)
            return 0 if live is None else len(live.subscribers)


def _call(loop: asyncio.AbstractEventLoop, fn: Callable[..., None], *args: Any) -> None:
    with contextlib.suppress(RuntimeError):  # a closed loop: the server is shutting down
        loop.call_soon_threadsafe(fn, *args)
