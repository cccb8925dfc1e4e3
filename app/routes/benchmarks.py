"""Benchmarks: listed with their progress, one with its summary (``tamp report``'s figures),
launched, cancelled and resumed (``app/benchmarks.py``); their horizon curves
(``app/horizon.py``)."""

from __future__ import annotations

from dataclasses import asdict
from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Path, Query

from app.benchmarks import BenchInfo
from app.deps import COMMON_RESPONSES, ERROR, Dash, bad_field, not_found
from app.errors import BusyError, NotLiveError, RequestError
from app.horizon import HorizonSeries
from app.schemas import BenchDetail, BenchOut, BenchRequest, ResumeRequest

router = APIRouter(prefix="/api/benchmarks", tags=["benchmarks"], responses=COMMON_RESPONSES)

BenchId = Annotated[str, Path(min_length=1, max_length=64, description="a benchmark id")]
BUSY: dict[int | str, dict[str, Any]] = {
    429: {**ERROR, "description": "the dashboard already runs a benchmark"}
}


def _out(info: BenchInfo) -> BenchOut:
    return BenchOut.model_validate(asdict(info))


@router.get("")
def list_benchmarks(dash: Dash) -> list[BenchOut]:
    """Every benchmark of the store, newest first: from the page and from ``tamp bench``."""
    return [_out(b) for b in dash.benches.list()]


@router.post("", status_code=202, responses=BUSY)
def launch(body: BenchRequest, dash: Dash) -> BenchOut:
    """Check and start a benchmark; it runs in the background (poll it for its progress)."""
    try:
        info = dash.benches.launch(
            scene=body.scene,
            planners=body.planners,
            trials=body.trials,
            seed_start=body.seed_start,
            budget_s=body.budget_s,
            model=body.model,
            workers=body.workers,
            order=body.order,
            max_queries=body.max_queries,
            max_iterations=body.max_iterations,
        )
    except RequestError as exc:
        raise bad_field(exc.field, str(exc)) from exc
    except BusyError as exc:
        raise HTTPException(429, detail=str(exc)) from exc
    return _out(info)


@router.get("/horizon")
def horizon(
    dash: Dash,
    domain: Annotated[
        str | None, Query(min_length=1, max_length=100, description="the domain's name")
    ] = None,
    planners: Annotated[
        str | None,
        Query(
            min_length=1,
            max_length=500,
            pattern=r"^[^,\s]+(,[^,\s]+)*$",
            description="the planners in their order, as tamp horizon takes them: "
            "baseline,paper,learned",
        ),
    ] = None,
    trials: Annotated[int | None, Query(ge=1, le=10**6, description="seeds per scene")] = None,
    seed_start: Annotated[int | None, Query(ge=0, le=2**62, description="the first seed")] = None,
    budget_s: Annotated[
        float | None, Query(gt=0, le=10**6, description="seconds per trial")
    ] = None,
    model: Annotated[
        str | None, Query(min_length=1, max_length=100, description="the model file's name")
    ] = None,
) -> list[HorizonSeries]:
    """The horizon curves the store's benchmarks make (``tamp horizon``'s): benchmarks of one
    domain with the same planners, seeds, budget and model over different scenes, each series
    with its points (per scene and planner: mean planning and total seconds, unsolved at the
    budget, with 95% bootstrap intervals) by the number of objects the scene's goal names.
    Done benchmarks, and running ones with the seeds every planner finished; newest first.
    The parameters pick the series with those settings."""
    try:
        return dash.horizon.series(
            domain=domain,
            planners=planners,
            trials=trials,
            seed_start=seed_start,
            budget_s=budget_s,
            model=model,
        )
    except RequestError as exc:
        raise bad_field(exc.field, str(exc), where="query") from exc


@router.get("/{bench_id}", responses={404: ERROR})
def get_benchmark(bench_id: BenchId, dash: Dash) -> BenchDetail:
    """The benchmark and what ``tamp report`` computes of it: per planner its trials, solved
    fraction, mean and median seconds and time split; the paired improvement of each planner
    over the first (and over ``learned``) with its bootstrap interval; every trial."""
    try:
        info, summary = dash.benches.summary(bench_id)
    except KeyError as exc:
        raise not_found(str(exc.args[0])) from exc
    return BenchDetail.model_validate({**asdict(info), "summary": summary})


@router.delete(
    "/{bench_id}",
    status_code=202,
    responses={404: ERROR, 409: {**ERROR, "description": "not running on this server"}},
)
def cancel(bench_id: BenchId, dash: Dash) -> BenchOut:
    """Stop a benchmark this server runs; its finished trials are kept (resumable)."""
    try:
        return _out(dash.benches.cancel(bench_id))
    except KeyError as exc:
        raise not_found(str(exc.args[0])) from exc
    except NotLiveError as exc:
        raise HTTPException(409, detail=str(exc)) from exc


@router.post(
    "/{bench_id}/resume",
    status_code=202,
    responses={404: ERROR, 409: {**ERROR, "description": "running, or nothing left"}, **BUSY},
)
def resume(bench_id: BenchId, body: ResumeRequest, dash: Dash) -> BenchOut:
    """Run the trials a stopped benchmark is missing (as ``tamp bench --resume`` does)."""
    try:
        return _out(dash.benches.resume(bench_id, body.workers))
    except KeyError as exc:
        raise not_found(str(exc.args[0])) from exc
    except NotLiveError as exc:
        raise HTTPException(409, detail=str(exc)) from exc
    except BusyError as exc:
        raise HTTPException(429, detail=str(exc)) from exc
