"""Fuzz the REST API from its own OpenAPI schema: no request may cause a server error, every
answer must match the schema, and what the schema calls invalid must be refused.

Schemathesis runs every check it has (status codes, content types, response schemas and
headers, invalid data refused, valid data accepted, ...). The one exception is that a launch
the schema allows may still be a 422 for the two reasons the schema documents but cannot
enumerate: a well-formed scene or model name that is not offered, or a model that does not fit
the scene's domain. Launches really run: the schema's example launches ``line-2`` (the tiny
pure-Python domain), and the last test checks that launches reached the planner and that
every run they made ended with a closing event.
"""

from __future__ import annotations

import tempfile
import time
import zlib
from pathlib import Path
from typing import Any

import pytest
import schemathesis
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, settings
from schemathesis.checks import negative_data_rejection
from schemathesis.specs.openapi.checks import positive_data_acceptance

from app.catalog import NAME
from app.main import create_app
from app.settings import Settings
from planner.api import MAX_BUDGET_S
from planner.store import FINAL_STATUSES, RunStore

_DB = Path(tempfile.mkdtemp(prefix="tamp-fuzz-")) / "runs.db"
APP = create_app(
    Settings(
        database_url=str(_DB),
        viewer=False,
        max_running=1,
        max_queued=2,  # a few valid launches wait; the rest are 429s
        cancel_grace_s=1.0,
        allowed_hosts=["testserver"],  # the host schemathesis's ASGI client sends
    )
)


async def _requests_only(scope: dict[str, Any], receive: Any, send: Any) -> None:
    """APP for schemathesis: requests pass through, its lifespan messages are answered here.

    Schemathesis starts an ASGI app's lifespan for each operation's test and shuts it down at the
    test's end; APP's shut-down cancels every queued run and stops the running one, so launches
    fuzzed in one operation would never plan. The module's ``lifespan`` fixture runs APP's
    start-up and shut-down once, around every test here.
    """
    if scope["type"] != "lifespan":
        await APP(scope, receive, send)
        return
    while True:
        message = await receive()
        if message["type"] == "lifespan.startup":
            await send({"type": "lifespan.startup.complete"})
        elif message["type"] == "lifespan.shutdown":
            await send({"type": "lifespan.shutdown.complete"})
            return


schema = schemathesis.openapi.from_asgi("/openapi.json", _requests_only)


@schema.hook
def map_case(context: schemathesis.HookContext, case: schemathesis.Case) -> schemathesis.Case:
    """Half the well-formed launches name ``line-2`` (so they reach the planner) and ask
    for little (so they end while the fuzzing goes on); bodies stay as valid or invalid."""
    if case.operation.label == "POST /api/runs":
        case.body = _small_line_launch(case.body)
    if case.operation.label == "POST /api/benchmarks":
        case.body = _small_benchmark(case.body)
    return case


def _small_benchmark(body: Any) -> Any:
    """A benchmark the schema allows, kept to a few short trials (a valid one really runs)."""
    if not isinstance(body, dict):
        return body
    trials, budget = body.get("trials", 1), body.get("budget_s", 5.0)
    if type(trials) is int and 1 <= trials <= 10_000:
        body = {**body, "trials": min(trials, 2)}
    if type(budget) in (int, float) and 0 < budget <= MAX_BUDGET_S:
        body = {**body, "budget_s": min(budget, 5.0)}
    return body


def _small_line_launch(body: Any) -> Any:
    if not isinstance(body, dict) or not isinstance(body.get("scene"), str):
        return body
    scene = body["scene"]
    if not NAME.match(scene) or (scene != "line-2" and zlib.crc32(scene.encode()) % 2):
        return body
    body = {**body, "scene": "line-2"}
    k, budget = body.get("k", 3), body.get("budget_s", 5.0)
    if type(k) is int and 1 <= k <= 1000:
        body["k"] = min(k, 3)
    if type(budget) in (int, float) and 0 < budget <= MAX_BUDGET_S:
        body["budget_s"] = min(budget, 5.0)
    return body


@pytest.fixture(scope="module", autouse=True)
def lifespan() -> object:
    with TestClient(APP) as client:  # runs the app's start-up and shut-down
        yield client


# The fields a well-formed request may still be refused for, by what is stored or offered:
# names that are not offered, a model of another domain, runs that cannot be trained on, ...
REFUSABLE = {
    "POST /api/runs": ("scene", "model"),
    "POST /api/benchmarks": ("scene", "model", "planners", "seed_start"),
    "POST /api/training": ("name", "runs", "benchmark"),
    "GET /api/benchmarks/horizon": ("domain", "planners", "model"),
}


def documented_refusals(ctx: Any, response: Any, case: schemathesis.Case) -> bool | None:
    """Valid data is accepted, except the refusals the schema documents."""
    meta = case.meta
    if meta is None or not meta.generation.mode.is_positive or response.status_code != 422:
        return positive_data_acceptance(ctx, response, case)
    fields = REFUSABLE.get(case.operation.label)
    assert fields is not None, (case.operation.label, response.text)
    detail = response.json()["detail"]
    for error in detail:
        loc = error["loc"]
        assert loc[:1] in (["body"], ["query"]) and len(loc) > 1 and loc[1] in fields, detail
        assert error["msg"], detail
    return None


def refused(ctx: Any, response: Any, case: schemathesis.Case) -> bool | None:
    """Invalid data is refused: a 4xx the check knows, or a 413 (the documented refusal of a
    body of more JSON values than the server takes, before it is parsed)."""
    if response.status_code == 413:
        detail = response.json()["detail"]
        assert detail.startswith("request body too large"), detail
        return None
    return negative_data_rejection(ctx, response, case)


@pytest.mark.slow
@schema.parametrize()
@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
def test_the_api_honours_its_schema(case: schemathesis.Case) -> None:
    case.call_and_validate(
        excluded_checks=[positive_data_acceptance, negative_data_rejection],
        additional_checks=[documented_refusals, refused],
    )


@pytest.mark.slow
def test_launches_from_the_schema_really_ran(lifespan: TestClient) -> None:
    # The launches made last (the operations are fuzzed one after another) get a while to
    # plan; then the queued and running ones end.
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and any(
        lifespan.get("/api/runs", params={"status": status}).json()["total"]
        for status in ("queued", "running")
    ):
        time.sleep(0.2)
    lifespan.app.state.dashboard.manager.close()
    with RunStore(_DB) as store:
        runs = store.list_runs(limit=500)
        planned = []
        for run in runs:
            assert run.status in FINAL_STATUSES, run
            events = store.events(run.id)
            assert events and events[-1].type in {"run_finished", "run_cancelled", "run_failed"}
            if any(e.type == "abstract_plans_found" for e in events):
                planned.append(run)
    assert any(r.scene == "line-2" for r in planned), [(r.scene, r.status) for r in runs]
