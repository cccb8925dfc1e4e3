"""Bad input gets a short 4xx naming the field, never a 500, and launches nothing."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from starlette.testclient import WebSocketDenialResponse

from app.main import create_app
from app.settings import Settings

LOCAL = "http://127.0.0.1:8000"
WS = "ws://127.0.0.1:8000"
JSON = {"content-type": "application/json"}


@pytest.fixture()
def client(tmp_path: Path) -> Iterator[TestClient]:
    settings = Settings(
        database_url=str(tmp_path / "runs.db"),
        viewer=False,
        max_queued=5,
        reports_dir=tmp_path / "reports",
    )
    with TestClient(create_app(settings), base_url=LOCAL) as c:
        yield c


def _field_error(response: Any, field: str) -> dict[str, Any]:
    assert response.status_code == 422, response.text
    detail = response.json()["detail"]
    named = [d for d in detail if d["loc"][-1] == field]
    assert named, detail
    return dict(named[0])


def _nothing_launched(client: TestClient) -> None:
    assert client.get("/api/runs").json()["total"] == 0


@pytest.mark.parametrize("number", ["NaN", "Infinity", "-Infinity"])
def test_non_finite_numbers_are_422_naming_the_field(client: TestClient, number: str) -> None:
    launch = client.post(
        "/api/runs", content=f'{{"scene": "line-2", "budget_s": {number}}}', headers=JSON
    )
    error = _field_error(launch, "budget_s")
    assert "finite" in error["msg"] and error["input"] == number
    view = client.put("/api/viewer", content=f'{{"run_id": "x", "step": {number}}}', headers=JSON)
    assert _field_error(view, "step")["input"] == number
    seed = client.post(
        "/api/runs", content=f'{{"scene": "line-2", "seed": {number}}}', headers=JSON
    )
    _field_error(seed, "seed")
    _nothing_launched(client)


@pytest.mark.parametrize("step", ["1e20", str(2**63), str(2**31), "-1", "2.5"])
def test_a_viewer_step_past_any_run_is_422(client: TestClient, step: str) -> None:
    response = client.put("/api/viewer", content=f'{{"run_id": "x", "step": {step}}}', headers=JSON)
    _field_error(response, "step")


def test_integers_past_what_sqlite_holds_are_422_everywhere(client: TestClient) -> None:
    run = client.post("/api/runs", json={"scene": "line-2", "k": 2}).json()
    for params, field in (
        ({"after": 2**63}, "after"),
        ({"after": -2}, "after"),
        ({"limit": 10**30}, "limit"),
    ):
        response = client.get(f"/api/runs/{run['id']}/events", params=params)
        _field_error(response, field)
    for params, field in (({"limit": 2**64}, "limit"), ({"offset": 2**63}, "offset")):
        _field_error(client.get("/api/runs", params=params), field)


@pytest.mark.parametrize("after", [str(2**63), "-2", "1e3", "x"])
def test_a_websocket_after_past_any_seq_is_refused_with_422(client: TestClient, after: str) -> None:
    run = client.post("/api/runs", json={"scene": "line-2", "k": 2}).json()
    with (
        pytest.raises(WebSocketDenialResponse) as refused,
        client.websocket_connect(f"{WS}/api/runs/{run['id']}/stream?after={after}"),
    ):
        pass
    assert refused.value.status_code == 422
    assert "after" in refused.value.json()["detail"]


def test_a_body_over_the_limit_is_413_and_never_read(client: TestClient) -> None:
    keys = ", ".join(f'"k{i}": {i}' for i in range(700_000))  # the 13 MB body of the finding
    body = f'{{"scene": "line-2", {keys}}}'.encode()
    assert len(body) > 10_000_000
    response = client.post("/api/runs", content=body, headers=JSON)
    assert response.status_code == 413 and "too large" in response.json()["detail"]
    assert len(response.content) < 300
    scene = json.dumps({"scene": "x" * 10_000_000})
    assert client.post("/api/runs", content=scene, headers=JSON).status_code == 413

    def chunks() -> Iterator[bytes]:  # no Content-Length: the limit counts what arrives
        for _ in range(20):
            yield b" " * 100_000

    chunked = client.post("/api/runs", content=chunks(), headers=JSON)
    assert chunked.status_code == 413
    assert client.get("/api/health").status_code == 200
    _nothing_launched(client)


def test_a_body_of_many_values_is_refused_before_it_is_parsed(client: TestClient) -> None:
    """60,000 keys in a megabyte held the event loop for seconds while they were parsed and
    each refused: a body of more JSON values than the server takes is a 413 before that."""
    keys = ", ".join(f'"key-{i}": {i}' for i in range(50_000))
    body = f'{{"scene": "line-2", {keys}}}'
    assert 500_000 < len(body) < 1_000_000  # under the byte limit
    response = client.post("/api/runs", content=body, headers=JSON)
    assert response.status_code == 413
    assert response.json()["detail"] == (
        "request body too large: about 50001 JSON values (this server takes 12000)"
    )
    _nothing_launched(client)


def test_a_large_bad_body_under_the_limits_gets_a_short_answer(client: TestClient) -> None:
    keys = ", ".join(f'"key-{i}": {i}' for i in range(10_000))
    body = f'{{"scene": "line-2", {keys}}}'
    response = client.post("/api/runs", content=body, headers=JSON)
    assert response.status_code == 422
    detail = response.json()["detail"]
    assert len(detail) == 21 and detail[-1]["msg"] == "and 9980 more errors"
    assert len(response.content) < 5_000
    long_scene = client.post("/api/runs", json={"scene": "a" * 500_000})
    error = _field_error(long_scene, "scene")
    assert error["input"] == "a" * 40 + "..." and len(long_scene.content) < 1_000
    long_key = client.post("/api/runs", json={"scene": "line-2", "z" * 100_000: 1})
    assert long_key.status_code == 422 and len(long_key.content) < 1_000
    _nothing_launched(client)


def test_a_body_that_is_not_json_is_422(client: TestClient) -> None:
    for content in ("{", "[1, 2]", "NaN", '"line-2"'):
        response = client.post("/api/runs", content=content, headers=JSON)
        assert response.status_code == 422, (content, response.text)
        assert response.json()["detail"][0]["loc"][0] == "body"
    _nothing_launched(client)


def test_a_body_that_is_not_utf8_is_422_naming_the_body(client: TestClient) -> None:
    """A JSON body must be UTF-8 text; another was a 400 "There was an error parsing the
    body" (FastAPI's), where the API promises a 422 for a bad body. With or without a
    content type (FastAPI reads a body that says none as JSON)."""
    body = b'{"scene": "line-2\xe9"}'
    for headers in (JSON, {}):
        response = client.post("/api/runs", content=body, headers=headers)
        assert response.status_code == 422, response.text
        (error,) = response.json()["detail"]
        assert error["loc"] == ["body", 17] and "not UTF-8" in error["msg"], error
        assert "0xe9" in error["msg"]
    response = client.put("/api/viewer", content=b'{"run_id": "\xff"}', headers=JSON)
    assert response.status_code == 422 and response.json()["detail"][0]["loc"][0] == "body"
    bom = b'\xef\xbb\xbf{"scene": "line-2", "seed": -1}'  # UTF-8 with its byte-order mark
    _field_error(client.post("/api/runs", content=bom, headers=JSON), "seed")
    _nothing_launched(client)
