"""Benchmarks: checked before any trial, interleaved, resumable, the same on a process pool and
on Ray, and a report with paired statistics."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest

from planner.bench import (
    BenchConfig,
    BenchError,
    check,
    code_revision,
    locate_model,
    make_config,
    run_bench,
    trial_order,
)
from planner.cli import main
from planner.domains import load_domain
from planner.domains.kitchen import MODEL as DEFAULT_MODEL
from planner.learning.model import CostModel
from planner.planners import get_planner
from planner.report import failure_kind, query_summary, render_html, summarize, table_markdown
from planner.store import BenchTrialRecord, QueryOutcome, RunStore
from tests.postgres import PostgresServer

LINE = str(Path(__file__).parent / "search" / "line-reach.json")  # a fast pure-Python scene
# Trials of LINE that solve (each seed in a few hundred queries, under a second) whatever the
# machine's load: bounded by queries, with seconds to spare (a busy machine once timed out a
# baseline trial of 60 s here).
SOLVES: dict[str, Any] = {"budget_s": 3600.0, "max_queries": 5000}


@pytest.mark.parametrize(
    ("kwargs", "says"),
    [
        ({"planners": ["baseline", "magic"]}, "unknown planner"),
        ({"planners": ["baseline", "baseline"]}, "twice"),
        ({"trials": 0}, "--trials"),
        ({"budget_s": 0.0}, "--budget"),
        ({"budget_s": 1e6}, "--budget"),
        ({"seed_start": -1}, "--seed-start"),
        ({"model": "m.pt"}, "only used by the learned planner"),
        ({"order": "fastest"}, "--order must be one of auto, plan, model"),
    ],
)
def test_bad_settings_fail_before_any_trial(kwargs: dict[str, object], says: str) -> None:
    args: dict[str, object] = {
        "planners": ["baseline"],
        "trials": 2,
        "seed_start": 0,
        "budget_s": 10.0,
    }
    args.update(kwargs)
    with pytest.raises(BenchError, match=says):
        make_config("line-2", **args)  # type: ignore[arg-type]


def test_the_model_must_fit_the_scene_and_not_have_seen_its_seeds(tmp_path: Path) -> None:
    model = CostModel.load(DEFAULT_MODEL, domain=load_domain("kitchen"))
    model.metadata["training_seeds"] = {"kitchen-4": list(range(20))}
    path = tmp_path / "m.pt"
    model.save(path)
    seen = make_config(
        "kitchen-4", ["baseline", "learned"], trials=5, seed_start=15, budget_s=10, model=str(path)
    )
    with pytest.raises(BenchError, match="trained on kitchen-4 seeds 15, 16, 17, 18, 19"):
        check(seen)
    held_out = make_config(
        "kitchen-4", ["baseline", "learned"], trials=5, seed_start=20, budget_s=10, model=str(path)
    )
    assert check(held_out)["training_seeds"] == {"kitchen-4": list(range(20))}
    other_domain = make_config(
        "line-2", ["baseline", "learned"], trials=1, seed_start=0, budget_s=10, model=str(path)
    )
    with pytest.raises(Exception, match="domain"):
        check(other_domain)


def test_a_resumed_benchmark_finds_its_model_by_content(tmp_path: Path) -> None:
    """Resuming from another checkout: the recorded model path is gone, but the shipped model is
    the same file; a model whose content changed is refused (one benchmark, one model)."""
    elsewhere = tmp_path / "old-checkout" / "model.pt"
    elsewhere.parent.mkdir()
    elsewhere.write_bytes(DEFAULT_MODEL.read_bytes())
    config = make_config(
        "kitchen-4", ["learned"], trials=1, seed_start=1000, budget_s=10, model=str(elsewhere)
    )
    sha = check(config)["model_sha256"]
    assert locate_model(config, sha) == config
    elsewhere.unlink()
    assert locate_model(config, sha).model == str(DEFAULT_MODEL)
    elsewhere.write_bytes(b"retrained")
    with pytest.raises(BenchError, match=r"model.pt has changed .* start a new benchmark"):
        locate_model(config, "0" * 64)
    assert locate_model(config, None) == config  # recorded before models were hashed


def test_model_priors_runs_learned_on_the_stores_priors_though_the_domain_ships_a_model() -> None:
    """``--model priors``: a learned trial runs as on a domain without a model (the priors of
    the benchmark's store), though kitchen ships one; no model file is read or hashed."""
    config = make_config(
        "kitchen-4", ["baseline", "learned"], trials=2, seed_start=1000, budget_s=10, model="priors"
    )
    assert check(config) == {"model": "priors", "training_seeds": None}
    assert {t.model for t in trial_order(config) if t.planner == "learned"} == {"priors"}
    assert locate_model(config, None) == config


def test_one_benchmark_holds_learned_with_its_model_and_on_priors() -> None:
    """``learned:model=priors`` runs on the store's priors beside ``learned`` with the model, in
    one paired benchmark (``model=FILE`` on another model file); only the learned planners take
    the setting, and a file that is not there is refused before any trial."""
    config = make_config(
        "kitchen-4",
        ["baseline", "learned", "learned:model=priors"],
        trials=1,
        seed_start=1000,
        budget_s=10,
    )
    models = {t.planner: t.model for t in trial_order(config)}
    assert models == {
        "baseline": None,
        "learned": str(DEFAULT_MODEL),
        "learned:model=priors": "priors",
    }
    with pytest.raises(ValueError, match="only paper and learned take model=priors"):
        get_planner("baseline:model=priors")
    with pytest.raises(BenchError, match=r"planner 'learned:model=other\.pt': no model file"):
        make_config(
            "kitchen-4",
            ["learned", "learned:model=other.pt"],
            trials=1,
            seed_start=1000,
            budget_s=10,
        )
    two = make_config(
        "kitchen-4",
        ["learned", f"learned:model={DEFAULT_MODEL}"],
        trials=1,
        seed_start=1000,
        budget_s=10,
    )
    assert {t.model for t in trial_order(two)} == {str(DEFAULT_MODEL)}


def test_a_model_order_gives_every_tree_search_the_model_and_is_kept_for_resume() -> None:
    config = make_config(
        "kitchen-4", ["baseline", "learned"], trials=2, seed_start=1000, budget_s=10, order="model"
    )
    trials = trial_order(config)
    assert {(t.planner, t.order, t.model) for t in trials} == {
        ("baseline", "model", str(DEFAULT_MODEL)),
        ("learned", "model", str(DEFAULT_MODEL)),
    }
    assert BenchConfig.from_dict(config.to_dict()) == config
    old = config.to_dict()
    del old["order"]  # a benchmark recorded before --order existed
    assert BenchConfig.from_dict(old).order == "auto"
    assert check(config)["model"] == str(DEFAULT_MODEL)
    plan_order = make_config("kitchen-4", ["baseline"], trials=1, seed_start=1000, budget_s=10)
    assert plan_order.model is None and trial_order(plan_order)[0].model is None
    sequential = make_config(
        "line-2", ["sequential"], trials=1, seed_start=0, budget_s=10, order="model"
    )
    with pytest.raises(BenchError, match="sequential: order 'model' is for the tree searches"):
        check(sequential)


def test_trials_are_paired_and_interleaved() -> None:
    config = BenchConfig("line-2", ("baseline", "sequential"), (5, 6, 7), 10.0)
    order = [(t.seed, t.planner) for t in trial_order(config)]
    assert order == [
        (5, "baseline"),
        (5, "sequential"),
        (6, "sequential"),
        (6, "baseline"),
        (7, "baseline"),
        (7, "sequential"),
    ]


def _outcomes(db: Path, bench_id: str) -> dict[tuple[int, str], tuple[str, int]]:
    with RunStore(db) as store:
        return {(t.seed, t.planner): (t.status, t.queries) for t in store.bench_trials(bench_id)}


@pytest.mark.slow
def test_process_pool_and_ray_give_the_same_outcomes_and_a_report(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    config = make_config(LINE, ["baseline", "sequential"], trials=2, seed_start=0, **SOLVES)
    local_db, ray_db = tmp_path / "local.db", tmp_path / "ray.db"
    local_id, local = run_bench(local_db, config, workers=2)
    assert len(local) == 4 and all(r.status == "solved" for r in local)

    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")
    monkeypatch.setenv("RAY_USAGE_STATS_ENABLED", "0")
    ray_id, on_ray = run_bench(ray_db, config, workers=2, ray_address="local")
    assert len(on_ray) == 4
    assert _outcomes(ray_db, ray_id) == _outcomes(local_db, local_id)  # same per-seed outcomes

    summary = summarize(local_db, local_id)
    assert summary["planners"]["baseline"]["solved"] == 2
    paired = summary["paired"]["sequential"]["total_censored"]
    assert paired["n"] == 2 and paired["low"] <= paired["mean"] <= paired["high"]
    # Two seeds: every view of the interval says it is rough (planner/figures.py).
    assert paired["note"] is not None and "only 2 seeds" in paired["note"]
    assert f"Note: {paired['note']}." in table_markdown(summary)
    page = render_html(summary)
    assert "only 2 seeds" in page
    assert "Plotly" in page and "sequential vs baseline" in page  # figures and the paired table
    assert "baseline (x)" in page
    assert page.count("href='/#run=") == 4  # every trial links to its run on the dashboard
    assert f"Code: {code_revision()}" in page  # the commit the figures came from
    # Every stored query is counted once, under its planner and stream.
    with RunStore(local_db) as store:
        for planner in ("baseline", "sequential"):
            runs = [t.run_id for t in store.bench_trials(local_id) if t.planner == planner]
            stored = store.stream_queries(run_ids=[r for r in runs if r])
            counted = summary["planners"][planner]["queries"]
            assert sum(e["queries"] for e in counted.values()) == len(stored)
            assert sum(e["failed"] for e in counted.values()) == sum(not q.success for q in stored)
        assert summary["planners"]["baseline"]["queries"]["test-reachable"]["failed"] > 0
    assert "Stream queries and why they failed" in page

    out = tmp_path / "report.html"
    assert main(["report", local_id, "--db", str(local_db), "--out", str(out)]) == 0
    assert out.stat().st_size > 1_000_000  # plotly inlined: the file opens anywhere


@pytest.mark.slow
def test_an_interrupted_benchmark_resumes_where_it_stopped(store_url: str) -> None:
    """On SQLite and on PostgreSQL: a trial whose run finished is never run again, even when
    the benchmark was killed before it saved the result; one killed mid-run is."""
    db = store_url
    config = make_config(LINE, ["baseline"], trials=3, seed_start=3, **SOLVES)
    bench_id, first = run_bench(db, config, workers=1)
    assert len(first) == 3
    runs = {r.trial.seed: r.run_id for r in first}
    with RunStore(db) as store, store.engine.begin() as conn:
        # Seed 4 finished but its result was not saved (the benchmark killed in between).
        conn.exec_driver_sql("DELETE FROM bench_trials WHERE seed = 4")
        # Seed 5 was killed while it planned: no result, and its run never finished.
        conn.exec_driver_sql("DELETE FROM bench_trials WHERE seed = 5")
        conn.exec_driver_sql(
            f"UPDATE runs SET status = 'running', owner = NULL WHERE id = '{runs[5]}'"
        )
        conn.exec_driver_sql(f"DELETE FROM events WHERE run_id = '{runs[5]}' AND seq > 3")
    _, again = run_bench(db, resume=bench_id, workers=1)
    assert [(r.trial.seed, r.trial.planner) for r in again] == [(5, "baseline")]
    outcomes = _outcomes(db, bench_id)
    assert outcomes[(4, "baseline")][0] == "solved"
    assert outcomes[(5, "baseline")][0] == "solved"
    with RunStore(db) as store:
        trials = {t.seed: t for t in store.bench_trials(bench_id)}
        assert trials[4].run_id == runs[4]  # the finished run, linked, not run again
        assert trials[4].queries == first[1].queries and trials[4].planning_s is not None
        assert trials[5].run_id != runs[5]
        assert store.get_run(runs[5]).status == "interrupted"  # the killed run, settled
        assert store.count_runs(status="solved") == 3  # seed 4 not run again
    with pytest.raises(BenchError, match="unknown benchmark"):
        run_bench(db, resume="nope")
    assert json.loads(json.dumps(summarize(db, bench_id)))["planners"]["baseline"]["trials"] == 3


@pytest.mark.parametrize("address", ["auto", "ray://10.0.0.5:10001", "10.0.0.5:6379"])
def test_a_sqlite_store_with_a_ray_cluster_is_refused_before_any_trial(
    tmp_path: Path, address: str
) -> None:
    """The cluster's other nodes cannot write to a file on this machine."""
    db = tmp_path / "b.db"
    config = make_config(LINE, ["baseline"], trials=2, seed_start=0, budget_s=60.0)
    for store in (db, f"sqlite:///{db}"):
        with pytest.raises(BenchError, match=r"SQLite file on this machine.*postgresql\+psycopg"):
            run_bench(store, config, ray_address=address)
    assert not db.exists()  # nothing recorded, no trial run


@pytest.mark.slow
def test_sigterm_stops_a_benchmark_cleanly_and_it_resumes(tmp_path: Path) -> None:
    """`kill` on a running `tamp bench` (the way to stop one started with `&`, which ignores
    Ctrl-C) marks it interrupted, keeps the trials that finished, stops the trial processes,
    and --resume runs only the rest."""
    import signal
    import subprocess
    import sys

    db = tmp_path / "k.db"
    cmd = [sys.executable, "-m", "planner.cli", "bench", "--scene", LINE, "--db", str(db)]
    proc = subprocess.Popen(
        [*cmd, "--planners", "baseline", "--trials", "8", "--budget", "60", "--workers", "1"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stderr is not None
    for line in proc.stderr:  # wait for the first finished trial
        if line.startswith("[1/8]"):
            break
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err[-2000:]
    with RunStore(db) as store:
        (bench,) = store.list_benches()
        assert bench.status == "interrupted"
        kept = len(store.bench_trials(bench.id))
    assert 1 <= kept < 8
    done = subprocess.run(
        [sys.executable, "-m", "planner.cli", "bench", "--resume", bench.id, "--db", str(db)],
        capture_output=True,
        text=True,
        check=False,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert f"[{8 - kept}/{8 - kept}]" in done.stderr  # only what was missing
    with RunStore(db) as store:
        assert len(store.bench_trials(bench.id)) == 8
        assert store.get_bench(bench.id).status == "done"


def test_failures_count_together_by_kind_most_first() -> None:
    def failed(stream: str, reason: str | None, error: str | None = None) -> QueryOutcome:
        return QueryOutcome("r", stream, False, 1.0, reason, error)

    outcomes = [
        failed("plan-motion", "base: no path in 150 iterations"),
        failed("plan-motion", "arm to rest: the start is in collision"),
        failed("plan-motion", "base: no path in 150 iterations"),
        QueryOutcome("r", "plan-motion", True, 0.5, None, None),
        failed("inverse-kinematics", "no arm configuration from 5 base poses (approach blocked 3)"),
        failed(
            "inverse-kinematics", "no arm configuration from 4 base poses (grasp in collision 2)"
        ),
        failed("plan-motion", "base: no path before the 10 s guard (87 of 150 iterations)"),
        failed("sample-pose", None, "RuntimeError: IK diverged"),
        failed("sample-pose", None),
    ]
    assert failure_kind(outcomes[0]) == "base: no path in N iterations"
    summary = query_summary(outcomes)
    motion = summary["plan-motion"]
    assert (motion["queries"], motion["failed"], motion["failed_s"]) == (5, 4, 4.0)
    assert [(k["kind"], k["count"]) for k in motion["kinds"]] == [
        ("base: no path in N iterations", 2),
        ("arm to rest: the start is in collision", 1),
        ("base: no path before the N s guard (N of N iterations)", 1),
    ]
    assert [(k["kind"], k["count"]) for k in summary["inverse-kinematics"]["kinds"]] == [
        ("no arm configuration from N base poses (approach blocked)", 1),
        ("no arm configuration from N base poses (grasp in collision)", 1),
    ]
    assert [k["kind"] for k in summary["sample-pose"]["kinds"]] == [
        "error: RuntimeError",
        "no reason given",
    ]


def test_a_benchmark_of_variants_reports_each_against_learned(tmp_path: Path) -> None:
    """An ablation (tamp bench --planners baseline,learned,learned:PART=off): the report pairs
    every planner with learned as well as with the reference, intervals in the same words."""
    planners = ["baseline", "learned", "learned:dead_ends=off"]
    # A few seconds each: the report's form is the point, not who wins (an unsolved trial
    # counts at the budget).
    config = make_config(LINE, planners, trials=2, seed_start=0, budget_s=3.0)
    db = tmp_path / "abl.db"
    bench_id, done = run_bench(db, config, workers=2)
    assert len(done) == 6
    summary = summarize(db, bench_id)
    against = summary["paired_against"]["learned"]
    assert set(against) == {"baseline", "learned:dead_ends=off"}
    assert against["baseline"]["total_censored"]["n"] == 2
    table = table_markdown(summary)
    assert "| planner | solved | total vs learned |" in table
    ablation = table[table.index("| planner | solved | total vs learned |") :]
    row = next(line for line in ablation.splitlines() if line.startswith("| learned:dead_ends"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    change = r"\d+\.\d% (less|more) \(\d+\.\d% (less|more) to \d+\.\d% (less|more)\)"
    # total and planning against learned, total against the baseline: a change and its
    # interval in the same words; execution too once a seed is solved by both, else "-".
    for cell in (cells[2], cells[3], cells[5]):
        assert re.fullmatch(change, cell), cell
    assert cells[4] == "-" or re.fullmatch(change, cells[4]), cells[4]


def test_a_benchmark_of_baseline_and_learned_has_no_ablation_section(tmp_path: Path) -> None:
    """With only the reference beside learned, "against learned" would be the paired figure
    the other way round: the report leaves it out (and the dashboard's summary skips it)."""
    db = tmp_path / "two.db"
    config = {"scene": "line-3", "planners": ["baseline", "learned"], "seeds": [0, 1, 2],
              "budget_s": 10.0, "model": None, "order": "auto", "domain": None}  # fmt: skip
    with RunStore(db) as store:
        bench_id = store.create_bench(config)
        for seed in config["seeds"]:
            for planner, planning in (("baseline", 4.0 + seed), ("learned", 2.0 + seed)):
                store.record_trial(
                    BenchTrialRecord(
                        bench_id=bench_id, seed=seed, planner=planner, run_id=None,
                        status="solved", valid=True, planning_s=planning, execution_s=5.0,
                        oracle_s=None, queries=0, error=None,
                    )
                )  # fmt: skip
        store.set_bench_status(bench_id, "done")
    summary = summarize(db, bench_id)
    assert summary["paired_against"] == {}
    assert summary["paired"]["learned"]["planning_censored"]["mean"] == pytest.approx(1 - 3 / 5)
    assert "total vs learned" not in table_markdown(summary)


def test_tamp_bench_refuses_a_sqlite_file_for_a_ray_cluster(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "b.db"
    argv = ["bench", "--scene", LINE, "--planners", "baseline", "--trials", "1", "--db", str(db)]
    assert main([*argv, "--ray-address", "auto"]) == 2
    error = capsys.readouterr().err
    assert "is a SQLite file on this machine" in error and "--ray-address local" in error
    assert not db.exists()


@pytest.mark.slow
def test_tamp_bench_and_report_take_a_postgresql_url(
    postgres: PostgresServer, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    url = postgres.new_database("cli")
    argv = ["bench", "--scene", LINE, "--planners", "baseline", "--trials", "1", "--db", url]
    assert main([*argv, "--workers", "1"]) == 0
    with RunStore(url) as store:
        (bench,) = store.list_benches()
        assert [t.status for t in store.bench_trials(bench.id)] == ["solved"]
    capsys.readouterr()
    assert main(["report", bench.id, "--db", url, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["planners"]["baseline"]["solved"] == 1
