"""Models: the ones offered, one with its provenance and validation figures, and training new
ones from stored runs (``app/training.py``)."""

from __future__ import annotations

from dataclasses import asdict
from typing import Annotated

from fastapi import APIRouter, HTTPException, Path

from app import catalog
from app.deps import COMMON_RESPONSES, ERROR, Dash, bad_field, not_found
from app.errors import BusyError, RequestError
from app.schemas import ModelDetail, ModelOut, TrainJobOut, TrainRequest
from app.training import TrainJob

router = APIRouter(prefix="/api", tags=["models"], responses=COMMON_RESPONSES)

ModelPath = Annotated[str, Path(min_length=1, max_length=100, description="a model's name")]
JobId = Annotated[str, Path(min_length=1, max_length=64, description="a training job's id")]


def _model(info: catalog.ModelInfo) -> ModelOut:
    fields = asdict(info)
    fields.pop("metadata")
    return ModelOut.model_validate(fields)


def _job(job: TrainJob) -> TrainJobOut:
    return TrainJobOut.model_validate(asdict(job))


@router.get("/models")
def models(dash: Dash) -> list[ModelOut]:
    return [_model(m) for m in dash.models.list()]


@router.get("/models/{name}", responses={404: ERROR})
def model(name: ModelPath, dash: Dash) -> ModelDetail:
    """A model with everything its file says: its domain, the runs and seeds it was trained
    on, where it came from, and its validation (per stream AUC of P_S, calibration, cost
    errors against the prior's) when the file holds it."""
    try:
        info = dash.models.info(name)
    except catalog.UnknownNameError as exc:
        raise not_found(str(exc.args[0])) from exc
    return ModelDetail.model_validate({**asdict(info), "metadata": info.metadata or {}})


@router.post(
    "/training",
    status_code=202,
    responses={429: {**ERROR, "description": "a training job is running"}},
)
def train(body: TrainRequest, dash: Dash) -> TrainJobOut:
    """Train a model from stored runs (the code of ``tamp train``) in the background; the
    model is offered under ``name`` once trained."""
    try:
        job = dash.training.submit(
            name=body.name,
            runs=body.runs,
            seed=body.seed,
            epochs=body.epochs,
            benchmark=body.benchmark,
        )
    except RequestError as exc:
        raise bad_field(exc.field, str(exc)) from exc
    except BusyError as exc:
        raise HTTPException(429, detail=str(exc)) from exc
    return _job(job)


@router.get("/training")
def jobs(dash: Dash) -> list[TrainJobOut]:
    """The training jobs of this server, newest first."""
    return [_job(j) for j in dash.training.list()]


@router.get("/training/{job_id}", responses={404: ERROR})
def job(job_id: JobId, dash: Dash) -> TrainJobOut:
    try:
        return _job(dash.training.get(job_id))
    except KeyError as exc:
        raise not_found(str(exc.args[0])) from exc
