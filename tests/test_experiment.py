"""Batches of recorded trials on a process pool: reproducible per seed, crashes recorded."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from planner.experiment import Trial, run_trials
from planner.store import RunStore

pytestmark = pytest.mark.slow

LINE = str(Path(__file__).parent / "search" / "line-reach.json")


def test_trials_are_recorded_and_reproducible(tmp_path: Path) -> None:
    trials = [Trial(LINE, seed, "baseline", 30.0) for seed in (1, 2, 3)]
    first = run_trials(trials, tmp_path / "a.db", workers=2)
    again = run_trials(trials, tmp_path / "b.db", workers=2)
    assert all(r.status == "solved" for r in first)

    def outcome(rs: list) -> dict[int, int]:  # type: ignore[type-arg]
        return {r.trial.seed: r.queries for r in rs}

    assert outcome(first) == outcome(again)  # same seeds, same searches
    store = RunStore(tmp_path / "a.db")
    runs = store.list_runs()
    assert sorted(r.seed for r in runs) == [1, 2, 3]
    assert all(r.status == "solved" for r in runs)
    assert len(store.stream_queries()) == sum(r.queries for r in first)


def test_a_crashing_trial_is_recorded_and_the_batch_goes_on(tmp_path: Path) -> None:
    trials = [Trial(LINE, 1, "baseline", 30.0), Trial("kitchen-99", 1, "baseline", 30.0)]
    lines: list[str] = []
    results = {
        r.trial.scene: r
        for r in run_trials(trials, tmp_path / "c.db", workers=1, progress=lines.append)
    }
    assert results["kitchen-99"].status == "failed"
    assert "unknown scene" in (results["kitchen-99"].error or "")
    assert results[LINE].status == "solved"
    statuses = {r.scene: r.status for r in RunStore(tmp_path / "c.db").list_runs()}
    assert statuses == {"kitchen-99": "failed", LINE: "solved"}
    # The progress line counts per planner, so a failure shows where it happened.
    assert lines[-1].startswith("[2/2] baseline 1/2 solved (median planning ")
    assert "about 0 s left" in lines[-1]


def test_a_model_trial_imports_torch_before_its_clock_starts(tmp_path: Path) -> None:
    # Library imports are process set-up for every planner: the baseline's come with
    # planner.runs; a learned trial must not pay torch's import as planning seconds.
    script = f"""
import sys
import planner.runs
from planner.experiment import Trial, run_trial
seen = []
def record_run(config, store, run_id):
    seen.append("torch" in sys.modules)
    raise RuntimeError("stop here")
planner.runs.record_run = record_run
for planner in ("baseline", "learned"):
    run_trial(Trial({LINE!r}, 1, planner, 30.0), {str(tmp_path / "t.db")!r})
print(seen)
"""
    out = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True, timeout=120
    )
    assert out.stdout.strip().splitlines()[-1] == "[False, True]"
