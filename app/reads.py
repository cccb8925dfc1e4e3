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
import contextlib
import ctypes
import logging
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass
from typing import TypeVar

from starlette.concurrency import run_in_threadpool

from planner.store import LIVE_STATUSES, RunRecord, RunStore

log = logging.getLogger(__name__)

READERS = 4  # chunks of events read from the store at once (threads of the pool they take)
CHUNK = 500  # events read per turn
TRIM_AFTER_S = 1.0  # once reads have stopped this long, free memory goes back to the system

T = TypeVar("T")


def _malloc_trim() -> None:
    """Give the C allocator's free memory back to the system. Each thread of the pool that built
    a chunk allocated it from an arena of its own, and glibc keeps freed arenas' pages: without
    this, a burst of readers left the server hundreds of MB larger for good. Nothing where the
    C library has no malloc_trim."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL("libc.so.6").malloc_trim(0)


class ReadGate:
    """At most ``readers`` store reads at once; the others wait their turn, first come first
    served (an :class:`asyncio.Semaphore` queues its waiters in order). When reads stop for
    :data:`TRIM_AFTER_S`, the memory they freed goes back to the system."""

    def __init__(self, readers: int = READERS) -> None:
        self.readers = readers
        self._sem: asyncio.Semaphore | None = None
        self.waiting = 0  # readers waiting for a turn now
        self.active = 0  # reads under way
        self.reads = 0  # reads done
        self.trims = 0  # times memory was given back
        self._trim: asyncio.TimerHandle | None = None

    def _semaphore(self) -> asyncio.Semaphore:
        if self._sem is None:  # made on the server's event loop, at the first read
            self._sem = asyncio.Semaphore(self.readers)
        return self._sem

    async def run(self, fn: Callable[..., T], *args: object, **kwargs: object) -> T:
        """``fn(*args, **kwargs)`` in the thread pool, in its turn."""
        sem = self._semaphore()
        if self._trim is not None:
            self._trim.cancel()
            self._trim = None
        self.waiting += 1
        try:
            await sem.acquire()
        finally:
            self.waiting -= 1
        self.active += 1
        try:
            return await run_in_threadpool(fn, *args, **kwargs)
        finally:
            self.active -= 1
            self.reads += 1
            sem.release()
            if self.active == 0 and self.waiting == 0:
                loop = asyncio.get_running_loop()
                self._trim = loop.call_later(TRIM_AFTER_S, self._give_back)

    def _give_back(self) -> None:
        self._trim = None
        self.trims += 1
        asyncio.get_running_loop().run_in_executor(None, _malloc_trim)


@dataclass(frozen=True)
class Chunk:
    """Events read in one turn: how many, the seq of the last, and their JSON texts one by
    one (the websocket sends them so) or joined by commas (a page streams them)."""

    count: int
    last: int
    texts: list[str]
    joined: bytes


def _read(store: RunStore, run_id: str, after: int, size: int, joined: bool) -> Chunk:
    """In a thread of the pool: the chunk, put together there (not on the event loop)."""
    rows = store.event_json(run_id, after=after, limit=size)
    last = rows[-1][0] if rows else after
    if joined:
        return Chunk(len(rows), last, [], ",".join(text for _, text in rows).encode())
    return Chunk(len(rows), last, [text for _, text in rows], b"")


async def event_chunks(
    gate: ReadGate,
    store: RunStore,
    run_id: str,
    after: int,
    limit: int | None,
    *,
    joined: bool = False,
) -> AsyncIterator[Chunk]:
    """The run's events with ``seq > after`` (at most ``limit``; None: all there are), in
    chunks each read in its turn. KeyError (at the first chunk) for an unknown run."""
    last, left = after, limit
    while left is None or left > 0:
        size = CHUNK if left is None else min(CHUNK, left)
        chunk = await gate.run(_read, store, run_id, last, size, joined)
        if chunk.count:
            yield chunk
            last = chunk.last
            if left is not None:
                left -= chunk.count
        if chunk.count < size:
            return


class EventPage:
    """One page of ``GET /api/runs/{id}/events``, streamed: ``{"events": [...], "next_after",
    "done", "last_seq"}`` (``done``: the run was over when the page was asked for, and the page
    holds every event after ``after``; ``last_seq``: the run's last stored seq then, so that a
    reader of a long run can ask for its other pages at once)."""

    def __init__(
        self, gate: ReadGate, store: RunStore, run_id: str, after: int, limit: int
    ) -> None:
        self.gate, self.store = gate, store
        self.run_id, self.after, self.limit = run_id, after, limit
        self._chunks: AsyncIterator[Chunk] | None = None
        self._first: Chunk | None = None
        self._over = False
        self._last_seq = -1

    async def start(self) -> None:
        """Read the run's status, its last stored seq and the first chunk (KeyError for an
        unknown run), so that a 404 is answered before anything is streamed."""
        record, self._last_seq = await self.gate.run(self._run_and_last)
        self._over = record.status not in LIVE_STATUSES
        self._chunks = event_chunks(
            self.gate, self.store, self.run_id, self.after, self.limit, joined=True
        )
        self._first = await anext(self._chunks, None)

    def _run_and_last(self) -> tuple[RunRecord, int]:
        return self.store.get_run(self.run_id), self.store.last_seq(self.run_id)

    async def body(self) -> AsyncIterator[bytes]:
        assert self._chunks is not None, "start() first"
        count = 0
        last = self.after
        chunk = self._first
        yield b'{"events":['
        while chunk is not None:
            if count:
                yield b","
            count += chunk.count
            last = chunk.last
            yield chunk.joined
            chunk = await anext(self._chunks, None)
        done = "true" if self._over and count < self.limit else "false"
        yield f'],"next_after":{last},"done":{done},"last_seq":{self._last_seq}}}'.encode()
