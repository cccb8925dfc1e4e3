"""The gate in front of the 3D view: the real viser server behind it, reached only through it,
framed only by the dashboard, and checked like the dashboard (Host, Origin, token)."""

from __future__ import annotations

import socket
import urllib.error
import urllib.request
from collections.abc import Iterator
from typing import Any

import pytest
import viser
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect
from websockets.typing import Origin, Subprotocol

from app.security import Access
from app.viewer import RunViewer
from app.viewgate import ViewerGate

PROTOCOL = Subprotocol(f"viser-v{viser.__version__}")
TOKEN = "a-token-of-twenty-chars"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="module")
def viewer() -> Iterator[RunViewer]:
    v = RunViewer(host="127.0.0.1", port=0)
    yield v
    v.close()


def _gate(viewer: RunViewer, **access: Any) -> ViewerGate:
    return ViewerGate(
        int(viewer.url.rpartition(":")[2]),
        host="127.0.0.1",
        port=_free_port(),
        access=Access(bound_host="127.0.0.1", **access),
        dashboard_port=8000,
    )


@pytest.fixture()
def gate(viewer: RunViewer) -> Iterator[ViewerGate]:
    g = _gate(viewer)
    yield g
    g.close()


def _get(url: str, **headers: str) -> tuple[int, dict[str, str], bytes]:
    request = urllib.request.Request(url, headers=headers)
    try:
        with urllib.request.urlopen(request, timeout=10) as response:
            return response.status, dict(response.headers), response.read()
    except urllib.error.HTTPError as exc:
        return exc.code, dict(exc.headers), exc.read()


def test_the_view_comes_through_the_gate_framed_only_by_the_dashboard(
    viewer: RunViewer, gate: ViewerGate
) -> None:
    status, headers, body = _get(gate.url() + "/")
    assert status == 200 and headers["Content-Type"].startswith("text/html")
    assert body == _get(viewer.url + "/")[2]  # the page viser serves, unchanged
    ancestors = headers["Content-Security-Policy"]
    assert ancestors.startswith("frame-ancestors ")
    assert "http://127.0.0.1:8000" in ancestors and "http://localhost:8000" in ancestors
    assert "*" not in ancestors and ":8080" not in ancestors
    assert gate.url("localhost:8000") == f"http://localhost:{gate.port}"
    with connect(gate.url().replace("http", "ws"), subprotocols=[PROTOCOL]) as ws:
        assert ws.subprotocol == PROTOCOL
        first = ws.recv(timeout=10)  # viser's first messages, relayed
        assert isinstance(first, bytes) and first


def test_the_gate_refuses_a_foreign_host_and_a_cross_origin_websocket(gate: ViewerGate) -> None:
    status, _, body = _get(gate.url() + "/", Host="evil.example")
    assert status == 400 and b"evil.example" in body
    url = gate.url().replace("http", "ws")
    with pytest.raises(InvalidStatus) as refused:
        connect(url, subprotocols=[PROTOCOL], origin=Origin("http://evil.example"))
    assert refused.value.response.status_code == 403
    with connect(url, subprotocols=[PROTOCOL], origin=Origin(gate.url())) as ws:
        assert ws.recv(timeout=10)


def test_the_gate_wants_the_token_cookie_when_the_server_has_a_token(viewer: RunViewer) -> None:
    gate = _gate(viewer, token=TOKEN)
    try:
        assert _get(gate.url() + "/")[0] == 401
        assert _get(gate.url() + "/", Cookie="tamp_token=wrong-wrong-wrong-wrong")[0] == 401
        assert _get(gate.url() + "/", Cookie=f"tamp_token={TOKEN}")[0] == 200
        url = gate.url().replace("http", "ws")
        with pytest.raises(InvalidStatus) as refused:
            connect(url, subprotocols=[PROTOCOL])
        assert refused.value.response.status_code == 401
        cookie = {"Cookie": f"tamp_token={TOKEN}"}
        with connect(url, subprotocols=[PROTOCOL], additional_headers=cookie) as ws:
            assert ws.recv(timeout=10)
    finally:
        gate.close()
