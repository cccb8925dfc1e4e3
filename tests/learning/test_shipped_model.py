"""The shipped model loads, covers the kitchen's streams, and a bad model path is one line."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from planner.learning.model import CostModel
from planner.runs import DEFAULT_MODEL


def test_shipped_model_predicts_every_kitchen_stream() -> None:
    model = CostModel.load(DEFAULT_MODEL, domain="kitchen")
    for stream in ("sample-grasp", "sample-placement", "inverse-kinematics", "plan-motion"):
        assert stream in model.streams
        width = model.featurizer.width(stream)
        pred = model.predict(stream, np.zeros((3, width), dtype=np.float32))
        assert len(pred) == 3
        assert np.all((pred.p_s >= 0) & (pred.p_s <= 1))
        assert np.all(pred.r_s >= 0) and np.all(pred.r_f >= 0) and np.all(pred.r_m >= 0)


def test_missing_model_is_a_clear_error() -> None:
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "planner.cli",
            "plan",
            "--scene",
            "kitchen-1",
            "--planner",
            "learned",
            "--model",
            "/nonexistent/model.pt",
            "--no-record",
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 2
    assert "/nonexistent/model.pt" in proc.stderr and "Traceback" not in proc.stderr
