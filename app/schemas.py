"""Request and response bodies of the REST API (the OpenAPI schema at ``/docs`` comes from here)."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from planner.store import RunRecord

PlannerName = Literal["baseline", "paper", "learned", "sequential"]
StatusName = Literal["queued", "running", "solved", "failed", "timeout", "cancelled", "interrupted"]


class RunRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")

    scene: str = Field(min_length=1, max_length=100, description="a scene name (GET /api/scenes)")
    planner: PlannerName = "baseline"
    seed: int = Field(0, ge=0, le=2**31 - 1)
    budget_s: float = Field(120.0, gt=0, le=3600, description="wall-clock seconds, top-k included")
    model: str | None = Field(
        None,
        min_length=1,
        max_length=100,
        description="learned only: a model name (GET /api/models)",
    )
    k: int = Field(50, ge=1, le=1000, description="skeletons asked of the top-k planner")


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
    database: str


class ViewerRequest(BaseModel):
    model_config = ConfigDict(extra="forbid")

    run_id: str = Field(min_length=1, max_length=64)
    step: int | None = Field(None, ge=0, description="show events 0..step; null: all, live")


class ViewerState(BaseModel):
    url: str | None
    run_id: str
    step: int | None


class Report(BaseModel):
    name: str
    url: str
