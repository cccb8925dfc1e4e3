"""Repeated reads of the runs list come from memory, yet show every change to the store at
once, whoever made it; a burst of identical reads reads the store once."""

from __future__ import annotations

import asyncio
from pathlib import Path
from typing import Any

from fastapi.testclient import TestClient

from app.main import create_app
from app.pagecache import ReadCache
from app.settings import Settings
from planner.store import RunStore


def test_the_runs_list_shows_changes_by_anyone_at_once(tmp_path: Path) -> None:
    db = tmp_path / "runs.db"
    settings = Settings(database_url=str(db), viewer=False, reports_dir=tmp_path)
    with TestClient(create_app(settings), base_url="http://127.0.0.1:8000") as client:
        assert client.get("/api/runs").json()["total"] == 0
        with RunStore(db) as other:  # another process's store: a tamp plan on the same file
            run_id = other.create_run("line-2", 0, "baseline", {})
            first = client.get("/api/runs")
            assert first.json()["total"] == 1 and first.json()["runs"][0]["status"] == "running"
            again = client.get("/api/runs")
            assert again.content == first.content
            assert again.headers["x-frame-options"] == "DENY"  # still checked and guarded
            other.finish_run(run_id, "solved", planning_s=1.25)
            (run,) = client.get("/api/runs").json()["runs"]
            assert (run["status"], run["planning_s"]) == ("solved", 1.25)
        assert client.get("/api/runs", params={"status": "failed"}).json()["total"] == 0
        assert client.get("/api/runs", params={"limit": 0}).status_code == 422
        assert client.get("/api/runs", headers={"host": "evil.example"}).status_code == 400


class _Store:
    """An ASGI app answering like a store read that takes a while, counting its reads."""

    def __init__(self) -> None:
        self.version = 1
        self.reads = 0

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        self.reads += 1
        await asyncio.sleep(0.05)
        status = 422 if b"bad" in scope["query_string"] else 200
        body = f"version {self.version}".encode()
        await send({"type": "http.response.start", "status": status, "headers": []})
        await send({"type": "http.response.body", "body": body})


async def _get(app: Any, query: bytes = b"limit=50") -> tuple[int, bytes]:
    sent: list[dict[str, Any]] = []

    async def receive() -> dict[str, Any]:
        return {"type": "http.request", "body": b""}

    async def send(message: dict[str, Any]) -> None:
        sent.append(message)

    scope = {"type": "http", "method": "GET", "path": "/api/runs", "query_string": query}
    await app(scope, receive, send)
    return sent[0]["status"], b"".join(m.get("body", b"") for m in sent[1:])


def test_a_burst_of_identical_reads_reads_the_store_once() -> None:
    async def scenario() -> None:
        store = _Store()
        cache = ReadCache(store, version=lambda: store.version)
        answers = await asyncio.gather(*(_get(cache) for _ in range(50)))
        assert answers == [(200, b"version 1")] * 50 and store.reads == 1
        assert await _get(cache) == (200, b"version 1") and store.reads == 1
        store.version = 2  # someone committed
        assert await _get(cache) == (200, b"version 2") and store.reads == 2
        assert await _get(cache, b"limit=10") == (200, b"version 2") and store.reads == 3
        for _ in range(3):  # refusals are not kept
            assert (await _get(cache, b"bad"))[0] == 422
        assert store.reads == 6

    asyncio.run(scenario())


def test_a_store_that_cannot_tell_its_version_is_read_every_time() -> None:
    async def scenario() -> None:
        store = _Store()
        cache = ReadCache(store, version=lambda: None)
        for _ in range(3):
            await _get(cache)
        assert store.reads == 3

    asyncio.run(scenario())
