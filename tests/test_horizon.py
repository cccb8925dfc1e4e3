"""The horizon curve (tamp horizon): one benchmark per scene, taken again when it is there,
points by the number of objects the goal names, a figure and a table."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from planner.bench import make_config
from planner.cli import main
from planner.horizon import (
    COLORS,
    find_bench,
    goal_objects,
    planner_colors,
    points,
    run_horizon,
    table_markdown,
    write,
)
from planner.store import RunStore

TUTORIAL = Path(__file__).resolve().parents[1] / "examples" / "tabletop2d"
SCENES = [str(TUTORIAL / "scenes" / f"tabletop-{n}.json") for n in (1, 2)]


def test_objects_are_the_goal_facts() -> None:
    assert [goal_objects(s) for s in SCENES] == [1, 2]
    assert goal_objects("kitchen-8") == 8


def test_a_series_runs_once_and_is_taken_again(tmp_path: Path) -> None:
    db = tmp_path / "h.db"
    settings = {"trials": 2, "seed_start": 0, "budget_s": 20.0}
    ids = run_horizon(db, SCENES, ["baseline", "sequential"], **settings, workers=1)
    assert len(ids) == 2
    with RunStore(db) as store:
        runs = len(store.list_runs())
    # The same command again takes the finished benchmarks: nothing runs.
    assert run_horizon(db, SCENES, ["baseline", "sequential"], **settings, workers=1) == ids
    with RunStore(db) as store:
        assert len(store.list_runs()) == runs
    config = make_config(SCENES[1], ["baseline", "sequential"], **settings)
    assert find_bench(db, config) == (ids[1], "done")

    pts = points(db, ids)
    assert [(p.objects, p.planner) for p in pts] == [
        (1, "baseline"),
        (1, "sequential"),
        (2, "baseline"),
        (2, "sequential"),
    ]
    for p in pts:
        mean, low, high = p.total
        assert low <= mean <= high and p.seeds == 2
        assert p.planning[0] <= p.total[0]
        assert (p.improvement is None) == (p.planner == "baseline")
    table = table_markdown(pts)
    assert table.count("\n") == 1 + len(pts) and "tabletop-2 | 2 | sequential" in table

    svg = tmp_path / "fig" / "h.svg"
    written = write(pts, svg, title="tutorial")
    assert written == [svg, svg.with_suffix(".json")]
    text = svg.read_text()
    # 2 planners x 2 panels, and each planner's skeleton seconds dashed in the planning panel
    assert text.startswith("<svg") and text.count("<polyline") == 6
    assert text.count('stroke-dasharray="5,4"') == 2
    assert json.loads(svg.with_suffix(".json").read_text())[0]["objects"] == 1
    html = write(pts, tmp_path / "h.html", title="tutorial")[0].read_text()
    assert "plotly" in html.lower()


def test_the_command_resumes_and_draws(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = str(tmp_path / "h.db")
    args = ["horizon", "--scenes", ",".join(SCENES), "--planners", "baseline", "--trials", "1"]
    args += ["--seed-start", "0", "--budget", "20", "--workers", "1", "--db", db]
    assert main([*args, "--no-run"]) == 2  # nothing to draw yet
    assert "no benchmark with these settings" in capsys.readouterr().err
    assert main([*args, "--out", str(tmp_path / "h.svg")]) == 0
    out = capsys.readouterr().out
    assert "| tabletop-1 | 1 | baseline | 1/1 |" in out and "wrote" in out
    # Titled by the scenes' family, the planners and the seeds.
    assert "tabletop: baseline, 1 seed a scene" in (tmp_path / "h.svg").read_text()
    assert main([*args, "--no-run"]) == 0
    assert main([*args, "--out", str(tmp_path / "h.png")]) == 2  # not a figure format
    assert "expected a .html or .svg file" in capsys.readouterr().err


def test_every_planner_counts_the_plan_s_execution_seconds() -> None:
    """The sequential binder counts the tutorial's paths as the tree searches do (it counted
    only values with the kitchen's trajectory segments, so elsewhere its total was planning)."""
    from planner.api import RunConfig, solve

    totals = {}
    for planner in ("baseline", "sequential"):
        out = solve(RunConfig(scene=SCENES[1], seed=0, planner=planner, budget_s=20))
        assert out.status == "solved"
        paths = [v for a in out.actions if a.name == "move" for v in [out.values[a.args[-1]]]]
        assert out.execution_s == pytest.approx(sum(p.seconds for p in paths)) and paths
        totals[planner] = out.execution_s
    assert all(s > 0 for s in totals.values())


def test_a_benchmark_run_from_another_checkout_is_found_by_its_model_s_content(
    tmp_path: Path,
) -> None:
    import hashlib

    from planner.domains.panda import MODEL
    from planner.horizon import _same

    wanted = make_config("panda-2", ["baseline", "learned"], trials=2, seed_start=1000, budget_s=60)
    assert wanted.model == str(MODEL)
    stored = {**wanted.to_dict(), "model": "/elsewhere/planner/domains/panda/model.pt"}
    stored["model_sha256"] = hashlib.sha256(MODEL.read_bytes()).hexdigest()
    assert _same(stored, wanted)
    assert not _same({**stored, "model_sha256": "0" * 64}, wanted)  # another model
    assert not _same({**stored, "budget_s": 30.0}, wanted)


def test_a_planner_has_one_colour_in_every_figure() -> None:
    """A kitchen curve of baseline and learned and a Panda curve of all three draw each planner
    alike; a variant takes a colour none of the three has."""
    two = planner_colors(["baseline", "learned"])
    three = planner_colors(["baseline", "paper", "learned", "learned:dead_ends=off"])
    assert two["learned"] == three["learned"] and two["baseline"] == three["baseline"]
    assert len(set(three.values())) == 4 and set(three.values()) <= set(COLORS)
