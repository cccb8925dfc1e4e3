"""Request and response bodies of the REST API (the OpenAPI schema at ``/docs`` comes from here)."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field

from app.catalog import NAME
from planner.api import MAX_BUDGET_S
from planner.status import BenchStatus, RunStatus, TrainStatus
from planner.store import RunRecord

PlannerName = Literal["baseline", "paper", "learned", "sequential"]

MAX_SEQ = 2**31 - 1  # event numbers and steps: far more than any run has
MAX_BOUND = 2**31 - 1  # a run's bound on queries or iterations: far more than any run makes

# Request bodies: no unknown fields, no coercion ("0" is not a number, true is not 1), finite
# numbers only, so the OpenAPI schema says exactly what the server accepts.
REQUEST = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)


def _integral(value: Any) -> Any:
    """JSON's integers: 461 and 461.0 (JSON Schema counts both), never "461" nor true."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


Integer = Annotated[int, BeforeValidator(_integral)]  # "integer" exactly as JSON Schema means it
# A run's bound on queries or iterations (RunConfig.max_queries, max_iterations); with the
# limits on the integer itself, so that the schema of an optional one says them.
Bound = Annotated[int, Field(ge=1, le=MAX_BOUND), BeforeValidator(_integral)]

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
    budget_s: float = Field(
        120.0, gt=0, le=MAX_BUDGET_S, description="wall-clock seconds, top-k included"
    )
    model: ModelName | None = None
    k: Integer = Field(50, ge=1, le=1000, description="skeletons asked of the top-k planner")
    max_queries: Bound | None = Field(
        None,
        description="stop after this many stream queries a sampler answered, whatever the "
        "seconds (the same point on any machine); none: budget_s alone",
    )
    max_iterations: Bound | None = Field(
        None,
        description="stop after this many search iterations (sequential: skeletons tried), "
        "whatever the seconds; none: budget_s alone",
    )


class Run(BaseModel):
    id: str
    scene: str
    seed: int
    planner: str
    status: RunStatus
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
    last_seq: int = Field(description="the run's last stored seq when the page was read")


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
    trained_at: str | None
    runs: int | None
    queries: int | None
    validated: bool = Field(description="the file holds its validation figures")
    source: Literal["shipped", "dashboard", "file"]


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
    node: Annotated[int, Field(ge=0, le=MAX_SEQ), BeforeValidator(_integral)] | None = Field(
        None, description="the search node to show: the bodies where it puts them, its samples"
    )


class ViewerState(BaseModel):
    url: str | None
    run_id: str
    step: int | None
    node: int | None = None


class Picked(BaseModel):
    node_id: int
    label: str
    count: int = Field(description="how many ghosts have been clicked so far (changes with each)")
    run_id: str | None = Field(None, description="the run shown when it was clicked")


class ViewerShown(BaseModel):
    url: str | None
    run_id: str | None
    step: int | None
    node: int | None
    picked: Picked | None = Field(description="the search node of the ghost last clicked")


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


# --- comparing two runs ------------------------------------------------------------------------


class TreeOut(BaseModel):
    """A run's search tree in columns, the nodes in the order they were made (the root
    first): node ``i`` is ``ids[i]``, its parent ``parents[i]`` and so on."""

    run_id: str
    ids: list[int]
    parents: list[int | None]
    plans: list[int] = Field(description="the stream plan of each node (-1: the root)")
    depths: list[int]
    streams: list[int] = Field(description="index into stream_names; -1: root or stream plan")
    stream_names: list[str]
    success: list[bool]
    q: list[float | None] = Field(description="the node's latest predicted Q (learned planners)")
    labels: list[str]
    solution: int | None = Field(description="the node that binds the whole plan, if found")
    plan_list: list[dict[str, Any]] = Field(description="the abstract plans (index, actions ...)")


class NodeRef(BaseModel):
    node_id: int
    parent_id: int | None
    plan_index: int
    depth: int
    stream: str | None
    success: bool
    label: str


class OutcomeDifference(BaseModel):
    index: int = Field(description="how many nodes both made before this one")
    a: NodeRef
    b: NodeRef
    text: str


class Divergence(BaseModel):
    """The first node the two searches made by different choices (app/compare.py)."""

    kind: Literal["choice", "prefix", "identical", "no tree"]
    same: int = Field(description="nodes both searches made alike before they parted")
    text: str
    a: NodeRef | None
    b: NodeRef | None
    outcome: OutcomeDifference | None = Field(
        description="the first query both made alike that ended otherwise (success, failure)"
    )


class TimeSplitOut(BaseModel):
    """Where a run's planning seconds went (planner.report.run_time_split), and execution."""

    planning_s: float
    until_plans_s: float = Field(description="until the first skeletons were found")
    later_skeletons_s: float = Field(
        default=0.0, description="the skeletons the search asked for after the first"
    )
    queries_s: float
    queries_by_stream_s: dict[str, float]
    search_s: float = Field(description="the rest: the search's own seconds")
    search_cpu_s: float | None = Field(
        default=None,
        description="the search thread's CPU seconds outside the queries, as the run recorded "
        "them (None for a run still going, or recorded before runs did)",
    )
    execution_s: float | None
    so_far: bool = Field(description="the run is still going")


class FailureKind(BaseModel):
    kind: str
    count: int
    seconds: float


class StreamQueries(BaseModel):
    queries: int
    failed: int
    failed_s: float
    kinds: list[FailureKind]


class Curve(BaseModel):
    t: list[float] = Field(description="seconds since the run started")
    queries: list[float] = Field(description="stream queries made by then")


class CompareSide(BaseModel):
    run: Run
    nodes: int
    split: TimeSplitOut
    queries: dict[str, StreamQueries]
    curve: Curve


class CompareOut(BaseModel):
    a: CompareSide
    b: CompareSide
    same_scene: bool
    notes: list[str] = Field(description="what to know before comparing (other scene or seed)")
    divergence: Divergence
    q_scale: tuple[float, float] | None = Field(
        description="one colour scale of Q for both trees (2nd to 98th percentile)"
    )


# --- benchmarks --------------------------------------------------------------------------------

PlannerSpecName = Annotated[
    str,
    Field(
        pattern=r"^[a-z]+(:[a-z_]+=[A-Za-z0-9_.+-]+)*$",
        max_length=200,
        description="a planner (baseline, paper, learned, sequential) or a variant such as "
        "learned:dead_ends=off",
        examples=["baseline", "learned:dead_ends=off"],
    ),
]


class BenchRequest(BaseModel):
    model_config = ConfigDict(
        **REQUEST,
        json_schema_extra={
            "examples": [{"scene": "line-2", "planners": ["baseline", "learned"], "trials": 2}]
        },
    )

    scene: SceneName
    planners: list[PlannerSpecName] = Field(
        ["baseline", "learned"],
        min_length=1,
        max_length=8,
        description="the first is the reference",
    )
    trials: Integer = Field(4, ge=1, le=10_000, description="seeds, each run by every planner")
    seed_start: Integer = Field(1000, ge=0, le=2**31 - 1)
    budget_s: float = Field(60.0, gt=0, le=MAX_BUDGET_S, description="seconds per trial")
    model: ModelName | None = Field(None, description="the learned planners' model by name")
    workers: Integer = Field(2, ge=1, le=16, description="trials at once")
    order: Literal["auto", "plan", "model"] = "auto"
    max_queries: Bound | None = Field(
        None, description="each trial's bound on stream queries (as RunRequest's)"
    )
    max_iterations: Bound | None = Field(
        None, description="each trial's bound on search iterations"
    )


class ResumeRequest(BaseModel):
    model_config = REQUEST

    workers: Integer = Field(2, ge=1, le=16, description="trials at once")


class PlannerProgressOut(BaseModel):
    done: int
    solved: int


class BenchOut(BaseModel):
    id: str
    scene: str
    planners: list[str]
    seeds: int
    seed_first: int
    seed_last: int
    budget_s: float
    model: str | None
    order: str
    status: BenchStatus = Field(description="interrupted and cancelled are resumable")
    created_at: datetime
    finished_at: datetime | None
    done: int = Field(description="trials finished")
    total: int = Field(description="trials in all: seeds x planners")
    progress: dict[str, PlannerProgressOut]
    runner: Literal["dashboard", "elsewhere"] | None = Field(
        description="who runs it: this dashboard, or another process (tamp bench)"
    )
    message: str


class BenchDetail(BenchOut):
    summary: dict[str, Any] = Field(description="planner.report.summarize: what tamp report shows")


# --- models and training -----------------------------------------------------------------------


class ModelDetail(ModelOut):
    metadata: dict[str, Any] = Field(description="what the file says about its training")


RunIdText = Annotated[str, Field(min_length=1, max_length=64)]


class TrainRequest(BaseModel):
    model_config = ConfigDict(
        **REQUEST,
        json_schema_extra={"examples": [{"name": "mine", "runs": ["<run id>", "<run id>"]}]},
    )

    name: ModelName = Field(description="the new model's name (not one offered already)")
    runs: list[RunIdText] = Field(min_length=1, max_length=10_000)
    seed: Integer = Field(0, ge=0, le=2**31 - 1)
    epochs: Integer = Field(300, ge=1, le=5000)
    benchmark: str | None = Field(
        None, min_length=1, max_length=64, description="the benchmark the runs are from"
    )


class TrainJobOut(BaseModel):
    id: str
    name: str
    domain: str
    runs: list[str]
    queries: int
    seed: int
    epochs: int
    status: TrainStatus
    created_at: datetime
    finished_at: datetime | None
    progress: float
    stream: str | None
    message: str
    report: dict[str, Any] | None
    benchmark: str | None
