"""Safe by default: a foreign Host or Origin is refused, nobody frames the dashboard, a token
guards REST, websocket and page alike, and binding beyond loopback needs consent."""

from __future__ import annotations

import json
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from pydantic import ValidationError
from starlette.testclient import WebSocketDenialResponse

from app.main import create_app
from app.settings import Settings

LOCAL = "http://127.0.0.1:8000"
WS = "ws://127.0.0.1:8000"
TOKEN = "correct-horse-battery-staple"


def _settings(tmp_path: Path, **overrides: Any) -> Settings:
    values: dict[str, Any] = {
        "database_url": str(tmp_path / "runs.db"),
        "viewer": False,
        "reports_dir": tmp_path / "reports",
    }
    values.update(overrides)
    return Settings(**values)


@pytest.fixture()
def client(tmp_path: Path) -> Iterator[TestClient]:
    with TestClient(create_app(_settings(tmp_path)), base_url=LOCAL) as c:
        yield c


def _refused(client: TestClient, url: str, **headers: str) -> int:
    with (
        pytest.raises(WebSocketDenialResponse) as refused,
        client.websocket_connect(url, headers=headers),
    ):
        pass
    return refused.value.status_code


def _launch(client: TestClient) -> str:
    response = client.post("/api/runs", json={"scene": "line-2", "k": 2})
    assert response.status_code == 202, response.text
    return str(response.json()["id"])


def test_a_foreign_host_is_refused(client: TestClient) -> None:
    """DNS rebinding: evil.example resolves to 127.0.0.1, the browser sends its name."""
    for path in ("/api/health", "/api/runs", "/", "/openapi.json"):
        response = client.get(path, headers={"host": "evil.example:8000"})
        assert response.status_code == 400, path
        assert "evil.example" in response.json()["detail"]
    refused = client.post("/api/runs", json={"scene": "line-2"}, headers={"host": "evil.example"})
    assert refused.status_code == 400
    run_id = _launch(client)
    stream = f"ws://evil.example:8000/api/runs/{run_id}/stream"
    assert _refused(client, stream) == 400
    for host in ("localhost:8000", "127.0.0.1:8000", "[::1]:8000", "LOCALHOST"):
        assert client.get("/api/health", headers={"host": host}).status_code == 200, host
    assert client.get("/api/runs").json()["total"] == 1  # only the local launch


def test_a_cross_origin_websocket_and_post_are_refused(client: TestClient) -> None:
    run_id = _launch(client)
    stream = f"{WS}/api/runs/{run_id}/stream"
    assert _refused(client, stream, origin="http://evil.example") == 403
    assert _refused(client, stream, origin="http://127.0.0.1:9999") == 403  # another port
    post = client.post(
        "/api/runs", json={"scene": "line-2"}, headers={"origin": "http://evil.example"}
    )
    assert post.status_code == 403
    with client.websocket_connect(stream, headers={"origin": LOCAL}) as ws:  # the page itself
        first = json.loads(ws.receive_text())
        assert first["type"] in {"run_started", "control"}
    assert client.get("/api/runs").json()["total"] == 1


def test_allowed_hosts_and_origins_widen_the_checks(tmp_path: Path) -> None:
    settings = _settings(
        tmp_path, allowed_hosts="dash.lan, other.lan", allowed_origins="http://tools.lan:3000"
    )
    with TestClient(create_app(settings), base_url="http://dash.lan:8000") as client:
        assert client.get("/api/health").status_code == 200
        assert client.get("/api/health", headers={"host": "other.lan"}).status_code == 200
        assert client.get("/api/health", headers={"host": "evil.lan"}).status_code == 400
        run_id = _launch(client)
        url = f"ws://dash.lan:8000/api/runs/{run_id}/stream"
        with client.websocket_connect(url, headers={"origin": "http://tools.lan:3000"}) as ws:
            assert json.loads(ws.receive_text())["type"]
        assert _refused(client, url, origin="http://evil.lan") == 403


def test_the_dashboard_cannot_be_framed_and_hides_its_database(
    client: TestClient, tmp_path: Path
) -> None:
    for path in ("/", "/api/health", "/api/runs", "/static/app.js"):
        response = client.get(path)
        assert response.headers["x-frame-options"] == "DENY", path
        assert "frame-ancestors 'none'" in response.headers["content-security-policy"]
    health = client.get("/api/health")
    assert health.json()["database"] == "sqlite"
    assert str(tmp_path) not in health.text and "runs.db" not in health.text


def test_a_token_guards_rest_websocket_and_page(tmp_path: Path) -> None:
    app = create_app(_settings(tmp_path, token=TOKEN))
    with TestClient(app, base_url=LOCAL) as client:
        for path in ("/api/health", "/", "/api/runs", "/openapi.json"):
            response = client.get(path)
            assert response.status_code == 401, path
            assert response.headers["www-authenticate"] == "Bearer"
        assert client.post("/api/runs", json={"scene": "line-2"}).status_code == 401
        wrong = {"authorization": "Bearer " + "x" * len(TOKEN)}
        assert client.get("/api/health", headers=wrong).status_code == 401
        bearer = {"authorization": f"Bearer {TOKEN}"}
        assert client.get("/api/health", headers=bearer).status_code == 200
        run_id = client.post("/api/runs", json={"scene": "line-2", "k": 2}, headers=bearer)
        stream = f"{WS}/api/runs/{run_id.json()['id']}/stream"
        assert _refused(client, stream) == 401
        with client.websocket_connect(stream, headers=bearer) as ws:
            assert json.loads(ws.receive_text())["type"]

        assert client.get("/?token=wrong-token-of-some-length").status_code == 401
        opened = client.get(f"/?token={TOKEN}", follow_redirects=False)
        assert opened.status_code == 303 and opened.headers["location"] == "/"
        cookie = opened.headers["set-cookie"]
        assert "tamp_token=" in cookie and "HttpOnly" in cookie and "SameSite=strict" in cookie
        client.cookies.set("tamp_token", TOKEN)  # what the browser keeps
        page = client.get("/")
        assert page.status_code == 200 and "<html" in page.text.lower()
        assert client.get("/api/health").status_code == 200
        with client.websocket_connect(stream) as ws:  # the page's websocket sends the cookie
            assert json.loads(ws.receive_text())["type"]


def test_binding_beyond_loopback_needs_a_token_or_consent(tmp_path: Path) -> None:
    with pytest.raises(ValidationError, match="allow-remote"):
        _settings(tmp_path, host="0.0.0.0")
    with pytest.raises(ValidationError, match="at least 16 characters"):
        _settings(tmp_path, host="0.0.0.0", token="short")
    assert not _settings(tmp_path, host="0.0.0.0", allow_remote=True).loopback
    assert _settings(tmp_path, host="0.0.0.0", token=TOKEN).token is not None
    assert _settings(tmp_path, host="localhost").loopback
    assert _settings(tmp_path, host="::1").loopback


def test_tamp_serve_refuses_an_open_remote_bind_and_warns_when_allowed(tmp_path: Path) -> None:
    tamp = str(Path(sys.executable).with_name("tamp"))
    args = ["serve", "--host", "0.0.0.0", "--no-viewer", "--db", str(tmp_path / "runs.db")]
    refused = subprocess.run([tamp, *args], capture_output=True, text=True, timeout=60)
    assert refused.returncode != 0
    assert "--allow-remote" in refused.stderr and "TAMP_TOKEN" in refused.stderr

    port = _free_port()
    log = tmp_path / "serve.log"
    with log.open("w") as out:
        server = subprocess.Popen(
            [tamp, *args, "--allow-remote", "--port", str(port)], stdout=out, stderr=out
        )
    try:
        health = _wait_json(f"http://127.0.0.1:{port}/api/health", server, log)
        assert health["status"] == "ok"
        text = log.read_text()
        assert "warning: bound to 0.0.0.0" in text and "NO authentication" in text
    finally:
        server.terminate()
        server.wait(timeout=30)


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _wait_json(url: str, server: subprocess.Popen[Any], log: Path) -> Any:
    deadline = time.monotonic() + 60
    while True:
        assert server.poll() is None, log.read_text()
        try:
            with urllib.request.urlopen(url, timeout=5) as response:
                return json.load(response)
        except OSError:
            assert time.monotonic() < deadline, log.read_text()
            time.sleep(0.2)
