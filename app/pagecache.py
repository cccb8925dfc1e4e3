"""Answers to repeated reads of the store, kept while the store is unchanged.

``GET /api/runs`` is what every open page asks every few seconds, and a burst of many requests
at once made the server's CPU (routing, validation, the query, serialisation) the whole of
their latency. :class:`ReadCache` is ASGI middleware that keeps each 200 answer of the cached
paths by its exact query string, labelled with the store's
:meth:`~planner.store.RunStore.data_version` when it was read, and sends it again while that
number is unchanged (any commit by anyone, a ``tamp plan`` on the same file included, changes
it). Concurrent misses of one query wait for the first one's answer instead of each reading the
store. Everything else, and a store that cannot tell its version, goes to the app as usual.
It sits inside :class:`~app.security.Guard`, so every request is still checked first.
"""

from __future__ import annotations

import asyncio
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass

from starlette.types import ASGIApp, Message, Receive, Scope, Send

Key = tuple[str, bytes]  # path, raw query string


@dataclass(frozen=True)
class _Answer:
    start: Message  # http.response.start
    body: bytes


class ReadCache:
    def __init__(
        self,
        app: ASGIApp,
        *,
        version: Callable[[], int | None],
        paths: tuple[str, ...] = ("/api/runs",),
        size: int = 64,
    ) -> None:
        self.app = app
        self.version = version
        self.paths = paths
        self.size = size
        self._answers: OrderedDict[Key, tuple[int, _Answer]] = OrderedDict()
        self._reading: dict[tuple[Key, int], asyncio.Future[_Answer | None]] = {}

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or scope["method"] != "GET" or scope["path"] not in self.paths:
            await self.app(scope, receive, send)
            return
        version = self.version()
        if version is None:
            await self.app(scope, receive, send)
            return
        key: Key = (scope["path"], scope.get("query_string", b""))
        kept = self._answers.get(key)
        if kept is not None and kept[0] == version:
            self._answers.move_to_end(key)
            await _send(kept[1], send)
            return
        reading = self._reading.get((key, version))
        if reading is not None:  # another request is reading this very answer
            answer = await asyncio.shield(reading)
            if answer is not None:
                await _send(answer, send)
            else:
                await self.app(scope, receive, send)
            return
        await self._read(key, version, scope, receive, send)

    async def _read(
        self, key: Key, version: int, scope: Scope, receive: Receive, send: Send
    ) -> None:
        future: asyncio.Future[_Answer | None] = asyncio.get_running_loop().create_future()
        self._reading[(key, version)] = future
        start: Message | None = None
        chunks: list[bytes] = []

        async def keep(message: Message) -> None:
            nonlocal start
            if message["type"] == "http.response.start":
                start = message
            elif message["type"] == "http.response.body":
                chunks.append(message.get("body", b""))
            await send(message)

        answer: _Answer | None = None
        try:
            await self.app(scope, receive, keep)
            if start is not None and start["status"] == 200:
                answer = _Answer(start, b"".join(chunks))
                self._answers[key] = (version, answer)
                self._answers.move_to_end(key)
                while len(self._answers) > self.size:
                    self._answers.popitem(last=False)
        finally:
            self._reading.pop((key, version), None)
            future.set_result(answer)


async def _send(answer: _Answer, send: Send) -> None:
    await send(answer.start)
    await send({"type": "http.response.body", "body": answer.body, "more_body": False})
