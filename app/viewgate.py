"""The 3D view as browsers reach it: a small proxy on the viewer port in front of viser.

The viser server has no checks of its own, so it listens on loopback at a free port and this
gate listens where users reach the view (``--host``, ``--viewer-port``). Every request gets the
dashboard's :class:`~app.security.Access` checks (``Host``, the websocket's ``Origin``, the
token cookie); pages are fetched from viser and sent on with ``Content-Security-Policy:
frame-ancestors`` naming the dashboard, so only the dashboard can frame the view; websockets
are relayed message by message both ways.
"""

from __future__ import annotations

import asyncio
import contextlib
import http
import logging
import threading
import urllib.error
import urllib.request
from collections.abc import Awaitable
from typing import Any

from websockets.asyncio.client import ClientConnection, connect
from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.datastructures import Headers
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response
from websockets.typing import Subprotocol

from app.security import Access, error_json, host_name

log = logging.getLogger(__name__)

PASSED_ON = ("Content-Type", "Content-Encoding", "Cache-Control", "Last-Modified")


class ViewerGate:
    """Serves ``127.0.0.1:upstream_port`` (viser) on ``host:port``, checked by ``access``;
    ``dashboard_port`` is the page's port, the one origin allowed to frame the view."""

    def __init__(
        self,
        upstream_port: int,
        *,
        host: str,
        port: int,
        access: Access,
        dashboard_port: int,
    ) -> None:
        self.upstream = f"127.0.0.1:{upstream_port}"
        self.access = access
        self.dashboard_port = dashboard_port
        self._loop = asyncio.new_event_loop()
        self._server: Server | None = None
        self._started = threading.Event()
        self._error: BaseException | None = None
        self._thread = threading.Thread(
            target=self._run, args=(host, port), name="viewer-gate", daemon=True
        )
        self._thread.start()
        self._started.wait(timeout=30)
        if self._error is not None:
            raise OSError(f"the 3D view cannot listen on {host}:{port}: {self._error}")
        if self._server is None:
            raise OSError(f"the 3D view did not start on {host}:{port}")
        self.port: int = int(next(iter(self._server.sockets)).getsockname()[1])

    def url(self, host_header: str | None = None) -> str:
        """The view's address for a page that reached the dashboard as ``host_header``."""
        name = host_name(host_header) if host_header else "127.0.0.1"
        return f"http://{f'[{name}]' if ':' in name else name}:{self.port}"

    def close(self) -> None:
        server = self._server
        if server is None:
            return
        self._loop.call_soon_threadsafe(server.close)
        self._thread.join(timeout=5)

    # --- the server's thread ----------------------------------------------------------------

    def _run(self, host: str, port: int) -> None:
        asyncio.set_event_loop(self._loop)
        try:
            self._loop.run_until_complete(self._serve(host, port))
        except BaseException as exc:  # reported to the constructor, which raises it
            self._error = exc
            self._started.set()
        finally:
            self._loop.close()

    async def _serve(self, host: str, port: int) -> None:
        async with serve(
            self._relay,
            host or None,
            port,
            process_request=self._gate,
            select_subprotocol=_viser_protocol,
            max_size=None,  # viser sends scenes of tens of MB; it bounds its own messages
            compression=None,
        ) as server:
            self._server = server
            self._started.set()
            await server.wait_closed()

    def _frame_ancestors(self) -> str:
        if self.access.any_host:
            return f"http://*:{self.dashboard_port} https://*:{self.dashboard_port}"
        sources = []
        for name in sorted(self.access.hosts):
            shown = f"[{name}]" if ":" in name else name
            sources.append(f"http://{shown}:{self.dashboard_port}")
        return " ".join(sources)

    def _response(self, status: int, body: bytes, headers: dict[str, str]) -> Response:
        out = Headers(
            {
                **headers,
                "Content-Length": str(len(body)),
                "Content-Security-Policy": f"frame-ancestors {self._frame_ancestors()}",
                "X-Content-Type-Options": "nosniff",
            }
        )
        return Response(status, http.HTTPStatus(status).phrase, out, body)

    async def _gate(self, connection: ServerConnection, request: Request) -> Response | None:
        headers = {k.lower(): v for k, v in request.headers.raw_items()}
        websocket = headers.get("upgrade", "").lower() == "websocket"
        if not websocket:
            headers.pop("origin", None)  # a page's own sub-resources; framing is the CSP's job
        refusal = self.access.check(headers)
        if refusal is not None:
            body = error_json(refusal.detail)
            return self._response(
                refusal.status, body, {"Content-Type": "application/json", **refusal.headers()}
            )
        if websocket:
            return None
        return await asyncio.to_thread(self._fetch, request.path, headers)

    def _fetch(self, path: str, headers: dict[str, str]) -> Response:
        wanted = {"Accept-Encoding": headers.get("accept-encoding", "identity")}
        upstream = urllib.request.Request(f"http://{self.upstream}{path}", headers=wanted)
        try:
            with urllib.request.urlopen(upstream, timeout=30) as answer:
                status, body, got = answer.status, answer.read(), answer.headers
        except urllib.error.HTTPError as exc:
            status, body, got = exc.code, exc.read(), exc.headers
        except OSError as exc:
            log.warning("3D view: viser did not answer %s: %s", path, exc)
            return self._response(
                502, b"the 3D view is not running", {"Content-Type": "text/plain"}
            )
        kept = {k: got[k] for k in PASSED_ON if got.get(k)}
        return self._response(status, body, kept)

    async def _relay(self, client: ServerConnection) -> None:
        path = client.request.path if client.request is not None else "/"
        protocols = [client.subprotocol] if client.subprotocol else None
        try:
            async with connect(
                f"ws://{self.upstream}{path}",
                subprotocols=protocols,
                max_size=None,
                compression=None,
                open_timeout=10,
            ) as upstream:
                await _pump_both(client, upstream)
        except (OSError, ConnectionClosed, TimeoutError) as exc:
            log.debug("3D view: a websocket ended: %s", exc)


def _viser_protocol(connection: ServerConnection, offered: Any) -> Subprotocol | None:
    return next((Subprotocol(p) for p in offered if p.startswith("viser-v")), None)


async def _pump_both(client: ServerConnection, upstream: ClientConnection) -> None:
    async def pump(source: Any, target: Any) -> None:
        async for message in source:
            await target.send(message)

    tasks: list[asyncio.Task[None]] = [
        asyncio.create_task(_quietly(pump(client, upstream))),
        asyncio.create_task(_quietly(pump(upstream, client))),
    ]
    _, pending = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
    for task in pending:
        task.cancel()
    await client.close()
    await upstream.close()


async def _quietly(work: Awaitable[None]) -> None:
    with contextlib.suppress(ConnectionClosed):
        await work
