"""Request and response bodies of the REST API (the OpenAPI schema at ``/docs`` comes from here)."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field

from app.catalog import NAME
from planner.store import RunRecord

PlannerName = Literal["baseline", "paper", "learned", "sequential"]
StatusName = Literal["queued", "running", "solved", "failed", "timeout", "cancelled", "interrupted"]

MAX_SEQ = 2**31 - 1  # event numbers and steps: far more than any run has

# Request bodies: no unknown fields, no coercion ("0" is not a number, true is not 1), finite
# numbers only, so the OpenAPI schema says exactly what the server accepts.
REQUEST = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)


def _integral(value: Any) -> Any:
    """JSON's integers: 461 and 461.0 (JSON Schema counts both), never "461" nor true."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


Integer = Annotated[int, BeforeValidator(_integral)]  # "integer" exactly as JSON Schema means it

SceneName = Annotated[
    str,
    Field(
        pattern=NAME.pattern,
        description="a scene name offered by GET /api/scenes: a letter or digit, then up to 99 "
        "letters, digits, '_', '.' or '-' (no paths); another name is a 422 listing the scenes",
        examples=["line-2", "kitchen-1"],
    ),
]
ModelName = Annotated[
    str,
    Field(
        pattern=NAME.pattern,
        description="learned only: a model name offered by GET /api/models (same characters "
        "as a scene name); another name is a 422 listing the models",
    ),
]


class RunRequest(BaseModel):
    model_config = ConfigDict(
        **REQUEST,
        json_schema_extra={"examples": [{"scene": "line-2", "k": 2, "budget_s": 10}]},
    )

    scene: SceneName
    planner: PlannerName = "baseline"
    seed: Integer = Field(0, ge=0, le=2**31 - 1)
    budget_s: float = Field(120.0, gt=0, le=3600, description="wall-clock seconds, top-k included")
    model: ModelName | None = None
    k: Integer = Field(50, ge=1, le=1000, description="skeletons asked of the top-k planner")


class Run(BaseModel):
    id: str
    scene: str
    seed: int
    planner: str
    status: str
    created_at: datetime
    finished_at: datetime | None
    planning_s: float | None
    execution_s: float | None
    oracle_s: float | None
    queries: int
    message: str
    config: dict[str, Any]

    @classmethod
    def of(cls, r: RunRecord) -> Run:
        return cls(
            id=r.id,
            scene=r.scene,
            seed=r.seed,
            planner=r.planner,
            status=r.status,
            created_at=r.created_at,
            finished_at=r.finished_at,
            planning_s=r.planning_s,
            execution_s=r.execution_s,
            oracle_s=r.oracle_s,
            queries=r.queries,
            message=r.message,
            config=r.config,
        )


class QueryCount(BaseModel):
    ok: int
    failed: int


class RunDetail(Run):
    plan: dict[str, Any] | None
    last_seq: int
    query_counts: dict[str, QueryCount]


class RunPage(BaseModel):
    runs: list[Run]
    total: int
    limit: int
    offset: int


class EventPage(BaseModel):
    events: list[dict[str, Any]]
    next_after: int
    done: bool


class SceneOut(BaseModel):
    name: str
    domain: str
    description: str
    blocks: int
    view: bool = Field(description="whether the domain has a 3D view")


class DomainOut(BaseModel):
    name: str
    source: str = Field(description="how it was found: an entry point or a folder")
    loaded: bool
    error: str | None = Field(description="why it does not load (its scenes are not offered)")
    description: str
    scenes: int


class ModelOut(BaseModel):
    name: str
    domain: str
    default: bool
    streams: list[str]
    bytes: int


class Health(BaseModel):
    status: str
    running: int
    queued: int
    viewer_url: str | None
    database: str = Field(description="the kind of database (sqlite, postgresql), not where")


class ViewerRequest(BaseModel):
    model_config = REQUEST

    run_id: str = Field(min_length=1, max_length=64)
    step: Annotated[int, Field(ge=0, le=MAX_SEQ), BeforeValidator(_integral)] | None = Field(
        None, description="show events 0..step; null: all, live"
    )


class ViewerState(BaseModel):
    url: str | None
    run_id: str
    step: int | None


class Report(BaseModel):
    name: str
    url: str


class ErrorOut(BaseModel):
    """Any error but a bad field: unknown run (404), already over (409), full queue (429),
    foreign Host (400), missing token (401), foreign origin (403), body too large (413)."""

    detail: str


class FieldError(BaseModel):
    loc: list[str | int] = Field(description="where: body / query / path, then the field")
    msg: str
    type: str
    input: Any = Field(None, description="the start of the value given, when it is short")


class ValidationErrorOut(BaseModel):
    """A 422: one entry per bad field (the first 20)."""

    detail: list[FieldError]
