"""Bounded reads of runs' events: no set of readers starves the others or holds the memory.

A page of 5,000 events of a kitchen run is megabytes of JSON. Read whole for each of 200
readers at once, it took every thread of the server's pool (so ``GET /api/runs`` and the health
check waited minutes) and held every page in memory at the same time (1.8 GB). Here:

- Events are read from the store in chunks of :data:`CHUNK` as the JSON the store holds
  (:meth:`planner.store.RunStore.event_json`: no parsing, no validation), and a reader takes
  one chunk at a time through :class:`ReadGate`: at most :data:`READERS` chunks are read at
  once, and a reader that wants another goes to the back of the queue, so a thousand readers
  each get their turn and the other routes keep the rest of the thread pool.
- A page is streamed to its reader chunk by chunk (the websocket's catch-up too): what the
  server holds for a reader is one chunk and what its socket has not taken yet.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Callable
from typing import TypeVar

from starlette.concurrency import run_in_threadpool

from planner.store import LIVE_STATUSES, RunStore

READERS = 4  # chunks of events read from the store at once (threads of the pool they take)
CHUNK = 500  # events read per turn

T = TypeVar("T")


class ReadGate:
    """At most ``readers`` store reads at once; the others wait their turn, first come first
    served (an :class:`asyncio.Semaphore` queues its waiters in order)."""

    def __init__(self, readers: int = READERS) -> None:
        self.readers = readers
        self._sem: asyncio.Semaphore | None = None
        self.waiting = 0  # readers waiting for a turn now
        self.reads = 0  # reads done

    def _semaphore(self) -> asyncio.Semaphore:
        if self._sem is None:  # made on the server's event loop, at the first read
            self._sem = asyncio.Semaphore(self.readers)
        return self._sem

    async def run(self, fn: Callable[..., T], *args: object, **kwargs: object) -> T:
        """``fn(*args, **kwargs)`` in the thread pool, in its turn."""
        sem = self._semaphore()
        self.waiting += 1
        try:
            await sem.acquire()
        finally:
            self.waiting -= 1
        try:
            return await run_in_threadpool(fn, *args, **kwargs)
        finally:
            self.reads += 1
            sem.release()


async def event_chunks(
    gate: ReadGate, store: RunStore, run_id: str, after: int, limit: int | None
) -> AsyncIterator[list[tuple[int, str]]]:
    """The run's events with ``seq > after`` (at most ``limit``; None: all there are), as
    chunks of ``(seq, JSON)``, each read in its turn. KeyError (at the first chunk) for an
    unknown run."""
    last, left = after, limit
    while left is None or left > 0:
        size = CHUNK if left is None else min(CHUNK, left)
        chunk = await gate.run(store.event_json, run_id, after=last, limit=size)
        if chunk:
            yield chunk
            last = chunk[-1][0]
            if left is not None:
                left -= len(chunk)
        if len(chunk) < size:
            return


class EventPage:
    """One page of ``GET /api/runs/{id}/events``, streamed: ``{"events": [...], "next_after",
    "done"}`` (``done``: the run was over when the page was asked for, and the page holds every
    event after ``after``)."""

    def __init__(
        self, gate: ReadGate, store: RunStore, run_id: str, after: int, limit: int
    ) -> None:
        self.gate, self.store = gate, store
        self.run_id, self.after, self.limit = run_id, after, limit
        self._chunks: AsyncIterator[list[tuple[int, str]]] | None = None
        self._first: list[tuple[int, str]] | None = None
        self._over = False

    async def start(self) -> None:
        """Read the run's status and the first chunk (KeyError for an unknown run), so that a
        404 is answered before anything is streamed."""
        record = await self.gate.run(self.store.get_run, self.run_id)
        self._over = record.status not in LIVE_STATUSES
        self._chunks = event_chunks(self.gate, self.store, self.run_id, self.after, self.limit)
        self._first = await anext(self._chunks, [])

    async def body(self) -> AsyncIterator[bytes]:
        assert self._chunks is not None and self._first is not None, "start() first"
        count = 0
        last = self.after
        chunk = self._first
        prefix = '{"events":['
        while chunk:
            count += len(chunk)
            last = chunk[-1][0]
            yield (prefix + ",".join(text for _, text in chunk)).encode()
            prefix = ","
            chunk = await anext(self._chunks, [])
        done = "true" if self._over and count < self.limit else "false"
        head = '{"events":[' if prefix != "," else ""
        yield f'{head}],"next_after":{last},"done":{done}}}'.encode()
