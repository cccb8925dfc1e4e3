"""Who may talk to the dashboard, and what it sends back to browsers.

A web page on any site can make the browser reach a server on localhost. So every request
(REST, websocket, the page, the 3D view) passes one :class:`Access` check first:

- the ``Host`` header names this server (localhost names, the bound address, and
  ``allowed_hosts``), which defeats DNS rebinding: 400 otherwise;
- an ``Origin`` header, which browsers send on websockets and on requests that change
  something, is the dashboard itself (or one of ``allowed_origins``): 403 otherwise;
- with a token set, the request carries it as ``Authorization: Bearer TOKEN`` or in the
  ``tamp_token`` cookie, which the page sets when it is opened as ``/?token=TOKEN``: 401
  otherwise.

:class:`Guard` applies it to the FastAPI app, with a request body limit (413), a JSON body that
is not UTF-8 refused as a 422 naming the body (as any body that is not JSON), and headers
that keep other sites from framing the dashboard; :mod:`app.viewgate` applies it to the 3D
view. Websocket refusals are HTTP responses to the handshake, with the same JSON ``detail``.
"""

from __future__ import annotations

import contextlib
import hmac
import json
import logging
import socket
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from http.cookies import CookieError, SimpleCookie
from typing import Any
from urllib.parse import parse_qs, urlsplit

from starlette.datastructures import Headers
from starlette.responses import JSONResponse, RedirectResponse, Response
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from app.settings import WILDCARD_HOSTS, Settings

log = logging.getLogger(__name__)

COOKIE = "tamp_token"
LOCAL_NAMES = ("localhost", "127.0.0.1", "::1")
# Sent with every dashboard response: nobody frames the dashboard (the 3D view is framed by
# it, see app.viewgate), and browsers take content types as given.
SECURITY_HEADERS = {
    "X-Frame-Options": "DENY",
    "Content-Security-Policy": "frame-ancestors 'none'",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
}


@dataclass(frozen=True)
class Refusal:
    status: int
    detail: str

    def headers(self) -> dict[str, str]:
        return {"WWW-Authenticate": "Bearer"} if self.status == 401 else {}


def host_name(host_header: str) -> str:
    """The name in a ``Host`` header (or an origin's netloc), lower case, without port."""
    host = host_header.strip().lower()
    if host.startswith("["):  # [::1]:8000
        return host[1 : host.find("]")] if "]" in host else host
    if host.count(":") == 1:
        host = host.partition(":")[0]
    return host.rstrip(".")


def _machine_names() -> set[str]:
    """This machine's own names and addresses, for a server bound to every interface."""
    names = {socket.gethostname().lower(), socket.getfqdn().lower()}
    with contextlib.suppress(OSError):
        names |= {str(info[4][0]) for info in socket.getaddrinfo(socket.gethostname(), None)}
    return names


class Access:
    """The checks of the module docstring, for one server's settings."""

    def __init__(
        self,
        *,
        bound_host: str,
        allowed_hosts: Iterable[str] = (),
        allowed_origins: Iterable[str] = (),
        token: str | None = None,
    ) -> None:
        hosts = {*LOCAL_NAMES, *(host_name(h) for h in allowed_hosts)}
        if bound_host in WILDCARD_HOSTS:
            hosts |= _machine_names()
        else:
            hosts.add(host_name(bound_host))
        self.hosts = frozenset(hosts)
        self.any_host = "*" in self.hosts
        self.origins = frozenset(o.rstrip("/").lower() for o in allowed_origins)
        self.any_origin = "*" in self.origins
        self.token = token

    @classmethod
    def of(cls, settings: Settings) -> Access:
        return cls(
            bound_host=settings.host,
            allowed_hosts=settings.allowed_hosts,
            allowed_origins=settings.allowed_origins,
            token=settings.token.get_secret_value() if settings.token else None,
        )

    def host_ok(self, host_header: str | None) -> bool:
        if not host_header:
            return False
        return self.any_host or host_name(host_header) in self.hosts

    def origin_ok(self, origin: str | None, host_header: str | None) -> bool:
        """No origin (not a browser, or a same-origin GET) is fine; a browser's must be the
        server it talks to, or one allowed by name."""
        if origin is None:
            return True
        origin = origin.rstrip("/").lower()
        if self.any_origin or origin in self.origins:
            return True
        parts = urlsplit(origin)
        return (
            parts.scheme in ("http", "https")
            and host_header is not None
            and parts.netloc == host_header.strip().lower()
        )

    def token_ok(self, authorization: str | None, cookie_header: str | None) -> bool:
        if self.token is None:
            return True
        given: list[str] = []
        if authorization and authorization[:7].lower() == "bearer ":
            given.append(authorization[7:].strip())
        if cookie_header:
            try:
                cookie = SimpleCookie(cookie_header)
            except CookieError:
                cookie = SimpleCookie()
            if COOKIE in cookie:
                given.append(cookie[COOKIE].value)
        expected = self.token.encode()
        return any(hmac.compare_digest(g.encode(), expected) for g in given)

    def check(self, headers: Mapping[str, str]) -> Refusal | None:
        """Why a request with these headers is refused, or None."""
        host = headers.get("host")
        if not self.host_ok(host):
            return Refusal(
                400,
                f"this server does not answer to host {_short(host or '')!r} (allowed: "
                "localhost, the address it was started on, and TAMP_ALLOWED_HOSTS)",
            )
        if not self.origin_ok(headers.get("origin"), host):
            return Refusal(
                403,
                f"requests from {_short(headers.get('origin', ''))!r} are not allowed (allowed: "
                "the dashboard itself and TAMP_ALLOWED_ORIGINS)",
            )
        if not self.token_ok(headers.get("authorization"), headers.get("cookie")):
            return Refusal(
                401,
                "this server needs its token (TAMP_TOKEN): send 'Authorization: Bearer "
                "TOKEN', or open the page once as /?token=TOKEN",
            )
        return None


def _short(text: str, most: int = 60) -> str:
    return text if len(text) <= most else text[:most] + "..."


class Guard:
    """ASGI middleware: :class:`Access`, the body limit and :data:`SECURITY_HEADERS`."""

    def __init__(
        self, app: ASGIApp, *, access: Access, max_body_bytes: int, max_json_items: int = 12_000
    ) -> None:
        self.app = app
        self.access = access
        self.max_body_bytes = max_body_bytes
        self.max_json_items = max_json_items

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = Headers(scope=scope)
        if scope["type"] == "http" and scope["path"] == "/" and self.access.token is not None:
            opened = self._open_with_token(scope, headers)
            if opened is not None:
                await opened(scope, receive, send)
                return
        refusal = self.access.check(headers)
        if refusal is not None:
            log.info(
                "refused %s %s: %d %s", scope["type"], scope["path"], refusal.status, refusal.detail
            )
            await _refuse(scope, receive, send, refusal)
            return
        if scope["type"] == "websocket":
            await self.app(scope, receive, send)
            return
        too_large = self._too_large(headers)
        if too_large is not None:
            await _refuse(scope, receive, send, too_large)
            return
        chunked = "chunked" in headers.get("transfer-encoding", "")
        # FastAPI parses a body as JSON when its type says so, or says nothing
        json_body = "json" in headers.get("content-type", "json") and scope["method"] != "GET"
        if ("content-length" not in headers and chunked) or json_body:
            body = await self._read_limited(receive)
            if body is None:
                await _refuse(scope, receive, send, self._limit_refusal(None))
                return
            items = _json_items(body) if json_body else 0
            if items > self.max_json_items:
                refusal = Refusal(
                    413,
                    f"request body too large: about {items} JSON values (this server takes "
                    f"{self.max_json_items})",
                )
                await _refuse(scope, receive, send, refusal)
                return
            not_text = _not_utf8(body) if json_body else None
            if not_text is not None:
                await not_text(scope, receive, send)
                return
            receive = _replay(body, receive)
        await self.app(scope, receive, _with_headers(send))

    def _open_with_token(self, scope: Scope, headers: Headers) -> Response | None:
        """``GET /?token=TOKEN``: the token becomes a cookie, the address loses it."""
        query = parse_qs(scope.get("query_string", b"").decode("latin-1"))
        given = query.get("token")
        if not given or not self.access.host_ok(headers.get("host")):
            return None
        if not self.access.token_ok(f"Bearer {given[0]}", None):
            return None  # refused below, like any request without the token
        response = RedirectResponse("/", status_code=303)
        response.set_cookie(COOKIE, given[0], httponly=True, samesite="strict", path="/")
        return response

    def _too_large(self, headers: Headers) -> Refusal | None:
        length = headers.get("content-length")
        if length is None:
            return None
        try:
            size = int(length)
        except ValueError:
            return Refusal(400, f"bad Content-Length {_short(length)!r}")
        return self._limit_refusal(size) if size > self.max_body_bytes else None

    def _limit_refusal(self, size: int | None) -> Refusal:
        said = f"{size} bytes" if size is not None else "more than that"
        return Refusal(
            413, f"request body too large: {said} (this server takes {self.max_body_bytes})"
        )

    async def _read_limited(self, receive: Receive) -> bytes | None:
        chunks: list[bytes] = []
        size = 0
        while True:
            message = await receive()
            if message["type"] != "http.request":
                return b"".join(chunks)
            chunk = message.get("body", b"")
            size += len(chunk)
            if size > self.max_body_bytes:
                return None
            chunks.append(chunk)
            if not message.get("more_body", False):
                return b"".join(chunks)


def _json_items(body: bytes) -> int:
    """About how many values a JSON text holds (its commas and its opening brackets; commas in
    strings count too, so never fewer): counted at C speed before it is parsed, since parsing
    and validating 60,000 keys held the event loop for seconds."""
    return body.count(b",") + body.count(b"[") + body.count(b"{")


def _not_utf8(body: bytes) -> Response | None:
    """A JSON body must be UTF-8 text (RFC 8259, 8.1): another is a 422 naming the body and
    the first byte that is not, as a body that is not JSON is (FastAPI answered 400 "There
    was an error parsing the body", where the API promises a 422); None for UTF-8 text."""
    try:
        body.decode("utf-8")
    except UnicodeDecodeError as exc:
        error = {
            "loc": ["body", exc.start],
            "msg": f"the body is not UTF-8 text: byte 0x{body[exc.start]:02x} at {exc.start} "
            "(a JSON body must be UTF-8)",
            "type": "json_invalid",
        }
        return JSONResponse({"detail": [error]}, status_code=422, headers=SECURITY_HEADERS)
    return None


def _replay(body: bytes, receive: Receive) -> Receive:
    sent = False

    async def replayed() -> Message:
        nonlocal sent
        if not sent:
            sent = True
            return {"type": "http.request", "body": body, "more_body": False}
        return await receive()

    return replayed


def _with_headers(send: Send) -> Send:
    extra = [(k.lower().encode(), v.encode()) for k, v in SECURITY_HEADERS.items()]

    async def sending(message: Message) -> None:
        if message["type"] == "http.response.start":
            message = {**message, "headers": [*message.get("headers", []), *extra]}
        await send(message)

    return sending


def refusal_response(refusal: Refusal) -> Response:
    headers = {**refusal.headers(), **SECURITY_HEADERS}
    return JSONResponse({"detail": refusal.detail}, status_code=refusal.status, headers=headers)


async def _refuse(scope: Scope, receive: Receive, send: Send, refusal: Refusal) -> None:
    response = refusal_response(refusal)
    if scope["type"] == "http":
        await response(scope, receive, send)
        return
    await receive()  # websocket.connect
    if "websocket.http.response" in scope.get("extensions", {}):
        await response(scope, receive, send)  # an HTTP answer to the handshake
    else:
        await send({"type": "websocket.close", "code": 1008, "reason": refusal.detail[:120]})


def error_json(detail: Any) -> bytes:
    return json.dumps({"detail": detail}).encode()
