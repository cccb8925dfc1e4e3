"""The FastAPI app: the API, the page (``static/``), plotly's JS, reports; ``serve`` runs it."""

from __future__ import annotations

import asyncio
import gc
import logging
import math
import sys
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

from fastapi import FastAPI, HTTPException, Request, WebSocket
from fastapi.exceptions import RequestValidationError, WebSocketRequestValidationError
from fastapi.responses import FileResponse, JSONResponse, Response
from fastapi.routing import APIRoute
from fastapi.staticfiles import StaticFiles
from starlette.routing import Match, Route

from app import catalog
from app.api import router
from app.pagecache import ReadCache
from app.routes import benchmarks, compare, models
from app.security import Access, Guard, Refusal, refusal_response
from app.services import Dashboard
from app.settings import WILDCARD_HOSTS, Settings
from planner import figures

log = logging.getLogger(__name__)

STATIC_DIR = Path(__file__).resolve().parent.parent / "static"
MAX_ERRORS = 20  # field errors listed in one 422
ECHO_CHARS = 40  # at most this much of a bad value is sent back


def plotly_js() -> Path:
    """plotly.min.js from the installed plotly package (never copied into the repo)."""
    import plotly

    path = Path(plotly.__file__).parent / "package_data" / "plotly.min.js"
    if not path.is_file():
        raise FileNotFoundError(f"plotly.min.js not found in the plotly package at {path}")
    return path


def _echo(value: Any) -> tuple[bool, Any]:
    """(whether to send it, what to send) of a bad value: short JSON-safe values as they
    are, the start of a long string, the name of a non-finite number, nothing of a container."""
    if value is None or isinstance(value, bool):
        return True, value
    if isinstance(value, int):
        return (True, value) if abs(value) < 10**15 else (True, f"{str(value)[:ECHO_CHARS]}...")
    if isinstance(value, float):
        if math.isfinite(value):
            return True, value
        return True, "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, str):
        return True, value if len(value) <= ECHO_CHARS else value[:ECHO_CHARS] + "..."
    return False, None


def field_errors(errors: Any) -> list[dict[str, Any]]:
    """Pydantic's errors as the 422 ``detail``: the first :data:`MAX_ERRORS`, each with its
    location (long keys cut short), message, type and at most the start of the value."""
    out: list[dict[str, Any]] = []
    for error in list(errors)[:MAX_ERRORS]:
        loc = [
            part[:ECHO_CHARS] + "..." if isinstance(part, str) and len(part) > ECHO_CHARS else part
            for part in error.get("loc", ())
        ]
        entry = {"loc": loc, "msg": str(error.get("msg", ""))[:200], "type": error.get("type", "")}
        send, value = _echo(error.get("input"))
        if send:
            entry["input"] = value
        out.append(entry)
    if len(errors) > MAX_ERRORS:
        out.append(
            {
                "loc": list(errors[MAX_ERRORS].get("loc", ()))[:1],
                "msg": f"and {len(errors) - MAX_ERRORS} more errors",
                "type": "too_many_errors",
            }
        )
    return out


def _store_version(app: FastAPI) -> int | None:
    dashboard: Dashboard | None = getattr(app.state, "dashboard", None)
    return None if dashboard is None else dashboard.store.data_version()


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or Settings()
    access = Access.of(settings)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        viewer = gate = None
        if settings.viewer:
            from app.viewer import RunViewer
            from app.viewgate import ViewerGate

            viewer = RunViewer(host="127.0.0.1", port=0)  # reached only through the gate
            upstream = int(viewer.url.rpartition(":")[2])
            gate = ViewerGate(
                upstream,
                host=settings.host,
                port=settings.viewer_port,
                access=access,
                dashboard_port=settings.port,
            )
        app.state.dashboard = Dashboard(settings, viewer=viewer, viewer_gate=gate)
        await asyncio.to_thread(app.state.dashboard.warm_up)
        # What start-up made (domains, models, torch, the routes) lives as long as the server:
        # out of the garbage collector's sight, a collection during a burst of requests walks
        # only what the requests made.
        gc.freeze()
        try:
            yield
        finally:
            app.state.dashboard.close()

    app = FastAPI(
        title="guided-tamp dashboard",
        description="Launch task-and-motion planning runs and watch their search grow.",
        version="0.1.0",
        lifespan=lifespan,
    )
    app.add_middleware(ReadCache, version=lambda: _store_version(app))
    app.add_middleware(  # outermost
        Guard,
        access=access,
        max_body_bytes=settings.max_body_bytes,
        max_json_items=settings.max_json_items,
    )

    @app.exception_handler(RequestValidationError)
    async def bad_request(_request: Request, exc: RequestValidationError) -> JSONResponse:
        return JSONResponse({"detail": field_errors(exc.errors())}, status_code=422)

    @app.exception_handler(405)
    async def wrong_method(request: Request, exc: Exception) -> JSONResponse:
        """Starlette names only the methods of the first route on the path; list them all."""
        allowed: set[str] = set()
        for route in app.router.routes:
            match, _ = route.matches(request.scope)
            if match == Match.PARTIAL and isinstance(route, APIRoute | Route):
                allowed |= route.methods or set()
        return JSONResponse(
            {"detail": "Method Not Allowed"},
            status_code=405,
            headers={"Allow": ", ".join(sorted(allowed))},
        )

    @app.exception_handler(WebSocketRequestValidationError)
    async def bad_websocket(websocket: WebSocket, exc: WebSocketRequestValidationError) -> None:
        errors = field_errors(exc.errors())
        detail = "; ".join(f"{'.'.join(map(str, e['loc']))}: {e['msg']}" for e in errors)
        if "websocket.http.response" in websocket.scope.get("extensions", {}):
            await websocket.send_denial_response(refusal_response(Refusal(422, detail)))
        else:
            await websocket.close(code=1008, reason=detail[:120])

    app.include_router(router)
    for resource in (compare, benchmarks, models):
        app.include_router(resource.router)
    app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")

    @app.get("/", include_in_schema=False)
    def index() -> FileResponse:
        return FileResponse(STATIC_DIR / "index.html")

    definitions = figures.definitions_js()

    @app.get("/generated/definitions.js", include_in_schema=False)
    def shared_definitions() -> Response:
        """planner/figures.py's definitions, as the page's module imports them."""
        return Response(definitions, media_type="text/javascript")

    @app.get("/vendor/plotly.min.js", include_in_schema=False)
    def plotly() -> FileResponse:
        return FileResponse(plotly_js(), media_type="application/javascript")

    @app.get("/reports/{name}", include_in_schema=False)
    def report(name: str) -> FileResponse:
        stem = name.removesuffix(".html")
        path = settings.reports_dir / f"{stem}.html"
        if not catalog.safe_name(stem) or not path.is_file():
            raise HTTPException(404, detail=f"no report {name!r}")
        return FileResponse(path)

    return app


def serve(settings: Settings) -> None:
    import uvicorn

    shown = "127.0.0.1" if settings.host in WILDCARD_HOSTS else settings.host
    token = f"?token={settings.token.get_secret_value()}" if settings.token else ""
    print(f"guided-tamp dashboard: http://{shown}:{settings.port}/{token}", flush=True)
    if settings.viewer:
        print(f"3D view: http://{shown}:{settings.viewer_port}/", flush=True)
    print(f"run store: {settings.database_url}", flush=True)
    if not settings.loopback:
        guard = (
            "every request needs the token (TAMP_TOKEN)"
            if settings.token
            else "there is NO authentication (--allow-remote): anyone who reaches it can "
            "launch runs and read every run"
        )
        print(
            f"warning: bound to {settings.host}, so the dashboard, its API and the 3D view are "
            f"reachable from other machines; {guard}",
            file=sys.stderr,
            flush=True,
        )
    uvicorn.run(create_app(settings), host=settings.host, port=settings.port, log_level="warning")
