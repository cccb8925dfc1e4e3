"""The FastAPI app: the API, the page (``static/``), plotly's JS, reports; ``serve`` runs it."""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

from fastapi import FastAPI, HTTPException
from fastapi.responses import FileResponse
from fastapi.staticfiles import StaticFiles

from app import catalog
from app.api import router
from app.services import Dashboard
from app.settings import Settings

log = logging.getLogger(__name__)

STATIC_DIR = Path(__file__).resolve().parent.parent / "static"


def plotly_js() -> Path:
    """plotly.min.js from the installed plotly package (never copied into the repo)."""
    import plotly

    path = Path(plotly.__file__).parent / "package_data" / "plotly.min.js"
    if not path.is_file():
        raise FileNotFoundError(f"plotly.min.js not found in the plotly package at {path}")
    return path


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or Settings()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        viewer = None
        if settings.viewer:
            from app.viewer import RunViewer

            viewer = RunViewer(host=settings.host, port=settings.viewer_port)
        app.state.dashboard = Dashboard(settings, viewer=viewer)
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
    app.include_router(router)
    app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")

    @app.get("/", include_in_schema=False)
    def index() -> FileResponse:
        return FileResponse(STATIC_DIR / "index.html")

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

    print(f"guided-tamp dashboard: http://{settings.host}:{settings.port}/", flush=True)
    if settings.viewer:
        print(f"3D view: http://{settings.host}:{settings.viewer_port}/", flush=True)
    print(f"run store: {settings.database_url}", flush=True)
    uvicorn.run(create_app(settings), host=settings.host, port=settings.port, log_level="warning")
