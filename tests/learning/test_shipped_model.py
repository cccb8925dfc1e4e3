"""The shipped model loads, covers the kitchen's streams, solves kitchen-4 seed 0, and a bad
model path is one line."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from planner.domains import load_domain
from planner.domains.kitchen import MODEL as DEFAULT_MODEL
from planner.learning.model import CostModel


def test_shipped_model_predicts_every_kitchen_stream() -> None:
    model = CostModel.load(DEFAULT_MODEL, domain=load_domain("kitchen"))
    for stream in ("sample-grasp", "sample-placement", "inverse-kinematics", "plan-motion"):
        assert stream in model.streams
        width = model.featurizer.width(stream)
        pred = model.predict(stream, np.zeros((3, width), dtype=np.float32))
        assert len(pred) == 3
        assert np.all((pred.p_s >= 0) & (pred.p_s <= 1))
        assert np.all(pred.r_s >= 0) and np.all(pred.r_f >= 0) and np.all(pred.r_m >= 0)


def _plan(*args: str) -> subprocess.CompletedProcess[str]:
    """`tamp plan ARGS --no-record` in a fresh interpreter, as a user runs it."""
    return subprocess.run(
        [sys.executable, "-m", "planner.cli", "plan", *args, "--no-record"],
        capture_output=True,
        text=True,
        check=False,
        timeout=600,
    )


def test_missing_model_is_a_clear_error() -> None:
    proc = _plan("--scene", "kitchen-1", "--planner", "learned", "--model", "/nonexistent/model.pt")
    assert proc.returncode == 2
    assert "/nonexistent/model.pt" in proc.stderr and "Traceback" not in proc.stderr


@pytest.mark.slow
def test_shipped_model_solves_kitchen_4_seed_0() -> None:
    """The learned planner works out of the box: `tamp plan --scene kitchen-4 --planner learned
    --seed 0` finds a plan with the shipped model, and the plan replays in simulation."""
    proc = _plan("--scene", "kitchen-4", "--planner", "learned", "--seed", "0", "--json")
    assert proc.returncode == 0, proc.stderr[-2000:]
    summary = json.loads(proc.stdout[proc.stdout.index("{") :])
    assert summary["status"] == "solved", summary
    assert summary["valid"] is True, summary["message"]
    assert summary["execution_s"] > 0
