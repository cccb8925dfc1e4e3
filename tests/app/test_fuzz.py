"""Fuzz the REST API from its own OpenAPI schema: no request may cause a server error."""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest
import schemathesis
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, settings
from schemathesis.checks import not_a_server_error

from app.main import create_app
from app.settings import Settings

_DB = Path(tempfile.mkdtemp(prefix="tamp-fuzz-")) / "runs"
APP = create_app(
    Settings(
        database_url=f"sqlite:///{_DB}.db",
        viewer=False,
        max_running=1,
        max_queued=0,  # a valid launch starts at most one run; the rest are 429s
        cancel_grace_s=1.0,
    )
)
schema = schemathesis.openapi.from_asgi("/openapi.json", APP)


@pytest.fixture(scope="module", autouse=True)
def lifespan() -> object:
    with TestClient(APP) as client:  # runs the app's start-up and shut-down
        yield client
    Path(f"{_DB}.db").unlink(missing_ok=True)


@pytest.mark.slow
@schema.parametrize()
@settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck))
def test_no_server_errors(case: schemathesis.Case) -> None:
    case.call_and_validate(checks=[not_a_server_error])
