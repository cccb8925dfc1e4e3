"""Routes: thin, every decision in :class:`app.services.Dashboard`."""

from __future__ import annotations

import json
import logging
from typing import Annotated, Any

from fastapi import (
    APIRouter,
    HTTPException,
    Path,
    Query,
    Request,
    WebSocket,
    WebSocketDisconnect,
)
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import Response, StreamingResponse

from app import reads
from app.deps import COMMON_RESPONSES, ERROR, RunId, bad_field, get_dashboard, not_found
from app.errors import RequestError
from app.hub import Ended, Lagged
from app.manager import QueueFullError, RunNotLiveError
from app.schemas import (
    MAX_SEQ,
    DomainOut,
    EventPage,
    Health,
    Picked,
    PlannerName,
    Report,
    Run,
    RunDetail,
    RunPage,
    RunRequest,
    SceneOut,
    ViewerRequest,
    ViewerShown,
    ViewerState,
)
from app.services import Dashboard
from planner.status import LIVE_STATUSES, RunStatus

log = logging.getLogger(__name__)

router = APIRouter(prefix="/api", responses=COMMON_RESPONSES)

MAX_PAGE = 5000  # events in one page of GET /api/runs/{id}/events


def _dash(request: Request) -> Dashboard:
    return get_dashboard(request)


def _unknown_run(run_id: str) -> HTTPException:
    return not_found(f"unknown run {run_id!r}")


@router.get("/health")
async def health(request: Request) -> Health:
    """On the event loop: it answers however busy the thread pool is."""
    dash = _dash(request)
    running, queued = dash.manager.counts()
    return Health(
        status="ok",
        running=running,
        queued=queued,
        viewer_url=dash.viewer_url(request.headers.get("host")),
        database=dash.store.backend,
    )


@router.get("/scenes")
def scenes(request: Request) -> list[SceneOut]:
    return [
        SceneOut(
            name=s.name, domain=s.domain, description=s.description, blocks=s.blocks, view=s.view
        )
        for s in _dash(request).domains.scenes()
    ]


@router.get("/domains")
def domains(request: Request) -> list[DomainOut]:
    dash = _dash(request)
    counts: dict[str, int] = {}
    for s in dash.domains.scenes():
        counts[s.domain] = counts.get(s.domain, 0) + 1
    return [
        DomainOut(
            name=d.name,
            source=d.source,
            loaded=d.error is None,
            error=d.error,
            description=d.description,
            scenes=counts.get(d.name, 0),
        )
        for d in dash.domains.infos()
    ]


@router.get("/reports")
def reports(request: Request) -> list[Report]:
    return [Report(**r) for r in _dash(request).reports()]


@router.post("/runs", status_code=202, responses={429: {**ERROR, "description": "queue full"}})
def launch(body: RunRequest, request: Request) -> Run:
    dash = _dash(request)
    try:
        record = dash.launch(**body.model_dump())
    except RequestError as exc:
        raise bad_field(exc.field, str(exc)) from exc
    except QueueFullError as exc:
        raise HTTPException(429, detail=str(exc)) from exc
    return Run.of(record)


@router.get("/runs")
def list_runs(
    request: Request,
    status: RunStatus | None = None,
    scene: Annotated[str | None, Query(max_length=100)] = None,
    planner: PlannerName | None = None,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
    offset: Annotated[int, Query(ge=0, le=10_000_000)] = 0,
) -> RunPage:
    """Newest first (repeated reads are answered by :class:`app.pagecache.ReadCache`)."""
    store = _dash(request).store
    runs = store.list_runs(status=status, scene=scene, planner=planner, limit=limit, offset=offset)
    total = store.count_runs(status=status, scene=scene, planner=planner)
    return RunPage(runs=[Run.of(r) for r in runs], total=total, limit=limit, offset=offset)


@router.get("/runs/{run_id}", responses={404: ERROR})
def get_run(run_id: RunId, request: Request) -> RunDetail:
    dash = _dash(request)
    try:
        record = dash.store.get_run(run_id)
        last_seq = dash.store.last_seq(run_id)
    except KeyError as exc:
        raise _unknown_run(run_id) from exc
    return RunDetail(
        **Run.of(record).model_dump(),
        plan=record.plan,
        last_seq=last_seq,
        query_counts=dash.query_counts(run_id),
    )


@router.get(
    "/runs/{run_id}/events",
    response_model=EventPage,
    responses={200: {"model": EventPage}, 404: ERROR},
)
async def get_events(
    run_id: RunId,
    request: Request,
    after: Annotated[int, Query(ge=-1, le=MAX_SEQ)] = -1,
    limit: Annotated[int, Query(ge=1, le=MAX_PAGE)] = 1000,
) -> Response:
    """Stored events with ``seq > after`` (only stored ones are ever served), streamed in
    chunks each read in its turn (:mod:`app.reads`); ``done``: the run is over and nothing
    comes after them."""
    page = reads.EventPage(_dash(request).reads, _dash(request).store, run_id, after, limit)
    try:
        await page.start()
    except KeyError as exc:
        raise _unknown_run(run_id) from exc
    return StreamingResponse(page.body(), media_type="application/json")


@router.delete(
    "/runs/{run_id}",
    status_code=202,
    responses={404: ERROR, 409: {**ERROR, "description": "the run is already over"}},
)
def cancel_run(run_id: RunId, request: Request) -> Run:
    dash = _dash(request)
    try:
        dash.manager.cancel(run_id)
        return Run.of(dash.store.get_run(run_id))
    except KeyError as exc:
        raise _unknown_run(run_id) from exc
    except RunNotLiveError as exc:
        raise HTTPException(409, detail=str(exc)) from exc


@router.put("/viewer", responses={404: ERROR})
def follow(body: ViewerRequest, request: Request) -> ViewerState:
    dash = _dash(request)
    try:
        dash.viewer.follow(body.run_id, body.step, body.node)
    except KeyError as exc:
        raise _unknown_run(body.run_id) from exc
    url = dash.viewer_url(request.headers.get("host"))
    return ViewerState(url=url, run_id=body.run_id, step=body.step, node=body.node)


@router.get("/viewer")
def shown(request: Request) -> ViewerShown:
    """What the 3D view shows, and the node of the ghost last clicked there (the page polls
    it to select that node)."""
    dash = _dash(request)
    run_id, step, node = dash.viewer.shown or (None, None, None)
    picked = dash.viewer.picked()
    if picked is not None and picked.run_id is not None and picked.run_id != run_id:
        picked = None  # a click in the run shown before (the view is about to forget it)
    return ViewerShown(
        url=dash.viewer_url(request.headers.get("host")),
        run_id=run_id,
        step=step,
        node=node,
        picked=None
        if picked is None
        else Picked(
            node_id=picked.node_id, label=picked.label, count=picked.count, run_id=picked.run_id
        ),
    )


@router.websocket("/runs/{run_id}/stream")
async def stream(
    websocket: WebSocket,
    run_id: Annotated[str, Path(min_length=1, max_length=64)],
    after: Annotated[int, Query(ge=-1, le=MAX_SEQ)] = -1,
) -> None:
    """Stored events with ``seq > after``, then live ones (docs/dashboard.md). Everything
    sent is in the store: stored events first, then the hub's batches, which workers send
    only once they are committed."""
    dash: Dashboard = websocket.app.state.dashboard
    await websocket.accept()
    try:
        await run_in_threadpool(dash.store.get_run, run_id)
    except KeyError:
        await websocket.send_text(_control("error", message=f"unknown run {run_id!r}"))
        await websocket.close(code=4404)
        return
    last = max(after, -1)
    try:
        while True:
            subscribed = dash.hub.subscribe(run_id, last)
            try:
                last = await _send_stored(websocket, dash, run_id, last)
                if subscribed is not None:
                    for event in subscribed[0]:
                        if event["seq"] > last:
                            await websocket.send_text(json.dumps(event))
                            last = event["seq"]
                await websocket.send_text(_control("caught_up", seq=last))
                if subscribed is None:
                    record = await run_in_threadpool(dash.store.get_run, run_id)
                    status = record.status if record.status not in LIVE_STATUSES else "unknown"
                    await websocket.send_text(_control("end", status=status))
                    await websocket.close()
                    return
                sub = subscribed[1]
                while True:
                    item = await sub.get()
                    if isinstance(item, Lagged):
                        await websocket.send_text(_control("resync", after=last))
                        break
                    if isinstance(item, Ended):
                        await websocket.send_text(_control("end", status=item.status))
                        await websocket.close()
                        return
                    for event in item:
                        if event["seq"] > last:
                            await websocket.send_text(json.dumps(event))
                            last = event["seq"]
            finally:
                if subscribed is not None:
                    dash.hub.unsubscribe(subscribed[1])
    except WebSocketDisconnect:
        log.debug("websocket client of run %s left", run_id)


async def _send_stored(websocket: WebSocket, dash: Dashboard, run_id: str, after: int) -> int:
    last = after
    async for chunk in reads.event_chunks(dash.reads, dash.store, run_id, after, None):
        for text in chunk.texts:
            await websocket.send_text(text)
        last = chunk.last
    return last


def _control(kind: str, **fields: Any) -> str:
    return json.dumps({"type": "control", "kind": kind, **fields})
