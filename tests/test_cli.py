"""The `tamp` command as a user runs it: output, exit codes, and one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from planner.cli import main


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "planner.cli", *args], capture_output=True, text=True, check=False
    )


@pytest.mark.slow
def test_abstract_json_lists_valid_unique_plans() -> None:
    proc = run("abstract", "--scene", "line-2", "--k", "5", "--planner", "kstar", "--json")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["backend"] == "kstar" and out["k"] == 5 and len(out["plans"]) == 5
    assert all(p["valid"] for p in out["plans"])
    assert len({tuple(p["actions"]) for p in out["plans"]}) == 5
    first = out["plans"][0]
    assert first["length"] == 4 and first["stream_plan"][0]["stream"] in (
        "sample-pose",
        "test-reachable",
    )
    assert set(out["seconds"]) == {"instantiate", "ground", "topk", "recover", "total"}
    # The default source: greedy searches, the cheapest first, as many as they find.
    proc = run("abstract", "--scene", "line-2", "--k", "5", "--json")
    adaptive = json.loads(proc.stdout)
    assert adaptive["backend"] == "adaptive" and 1 <= len(adaptive["plans"]) <= 5
    assert all(p["valid"] for p in adaptive["plans"])
    assert adaptive["plans"][0]["cost"] == first["cost"]  # as cheap as K*'s cheapest


@pytest.mark.slow
def test_abstract_text_output_and_problem_file(capsys: pytest.CaptureFixture[str]) -> None:
    problem = Path(__file__).parent.parent / "planner/domains/line/problems/line-2.pddl"
    args = ["abstract", "--domain", "line", "--problem", str(problem), "--k", "2", "--show", "1"]
    code = main([*args, "--planner", "kstar"])
    out = capsys.readouterr().out
    assert code == 0
    assert "2 of 2 skeletons from kstar" in out
    assert "stream sample-pose(" in out and "(pick a pa start)" in out


def test_unknown_scene_is_one_line_without_traceback() -> None:
    proc = run("abstract", "--scene", "kitchen-99")
    assert proc.returncode == 2
    assert "unknown scene 'kitchen-99'" in proc.stderr and "kitchen-4" in proc.stderr
    assert "Traceback" not in proc.stderr


@pytest.mark.parametrize("k", ["0", "-3", "100001", "many"])
def test_bad_k_is_an_argument_error(k: str) -> None:
    proc = run("abstract", "--scene", "kitchen-1", "--k", k)
    assert proc.returncode == 2 and "argument --k" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_malformed_problem_file_gives_file_line_column(tmp_path: Path) -> None:
    bad = tmp_path / "broken.pddl"
    bad.write_text("(define (problem p) (:domain line)\n  (:objects a - block)\n  (:init (at a)")
    proc = run("abstract", "--domain", "line", "--problem", str(bad))
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert f"{bad}:3:" in proc.stderr and "expected ')'" in proc.stderr


def test_problem_needs_domain() -> None:
    proc = run("abstract", "--problem", "x.pddl")
    assert proc.returncode == 2 and "--problem needs --domain" in proc.stderr


def test_scenes(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["scenes"]) == 0
    listed = capsys.readouterr().out.split()
    assert {"kitchen-8", "kitchen-10", "kitchen-12"} <= set(listed)


def test_serve_rejects_bad_settings_before_starting() -> None:
    proc = run("serve", "--port", "70000", "--no-viewer")
    assert proc.returncode != 0
    assert "port" in proc.stderr and "65535" in proc.stderr
    assert "Traceback" not in proc.stderr
