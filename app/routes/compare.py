"""Two runs side by side, and one run's tree in columns (``app/compare.py``)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query

from app.compare import columns, compare_runs
from app.deps import COMMON_RESPONSES, ERROR, Dash, RunId, not_found
from app.schemas import CompareOut, Run, TreeOut

router = APIRouter(prefix="/api", tags=["compare"], responses=COMMON_RESPONSES)

RunQuery = Annotated[str, Query(min_length=1, max_length=64, description="a run id")]


@router.get("/runs/{run_id}/tree", responses={404: ERROR})
def tree(run_id: RunId, dash: Dash) -> TreeOut:
    """The run's search tree (planner/trace.py's fold of its events) as the compare view
    draws it."""
    try:
        t = dash.trees.get(run_id)
    except KeyError as exc:
        raise not_found(f"unknown run {run_id!r}") from exc
    c = columns(t)
    return TreeOut(
        run_id=c.run_id,
        ids=c.ids,
        parents=c.parents,
        plans=c.plans,
        depths=c.depths,
        streams=c.streams,
        stream_names=c.stream_names,
        success=c.success,
        q=c.q,
        labels=c.labels,
        solution=c.solution,
        plan_list=c.plan_list,
    )


@router.get("/compare", responses={404: ERROR})
def compare(a: RunQuery, b: RunQuery, dash: Dash) -> CompareOut:
    """Runs ``a`` and ``b`` side by side: their time splits, queries per stream, queries made
    against seconds, where the searches chose differently, and one colour scale for their
    trees. Runs of different scenes are compared too, and the notes say so."""
    try:
        data = compare_runs(dash.store, dash.trees, a, b)
    except KeyError as exc:
        raise not_found(str(exc.args[0])) from exc
    sides = {side: {**data[side], "run": Run.of(data[side]["run"])} for side in ("a", "b")}
    return CompareOut.model_validate({**data, **sides})  # data may be kept: not changed
