"""A benchmark on a Ray cluster of several nodes (``ray.cluster_utils.Cluster``: a head and two
worker nodes on this machine, each its own raylet) into a PostgreSQL store: a node that dies
mid-benchmark crashes the trial it ran, and ``--resume`` completes the benchmark with every
seed's trial stored once."""

from __future__ import annotations

import json
import shutil
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from planner.bench import make_config, run_bench
from planner.experiment import TrialResult
from planner.store import RunStore
from tests.postgres import PostgresServer

LINE = Path(__file__).resolve().parents[1] / "planner" / "domains" / "line"

# The line domain, whose pose sampler waits while a file "hold" lies beside it: trials that
# stay running until the test lets them go.
HOLD_DOMAIN = '''
"""line, whose pose sampler waits while the file "hold" exists beside this module."""

import time
from pathlib import Path

from planner.domains import DomainSpec
from planner.domains.line import REACH_KEY, problem_from_scene
from planner.streams.adapters import Failure, from_fn, from_test

HOLD = Path(__file__).with_name("hold")


def bindings(problem, rng):
    reach = float(problem.values.get(REACH_KEY, float("inf")))

    def sample_pose(width, region):
        while HOLD.exists():
            time.sleep(0.05)
        lo, hi = region
        if hi - lo < width:
            return Failure("the region is too narrow")
        return (rng.uniform(lo + width / 2, hi - width / 2),)

    def reachable(width, x):
        return abs(x) + width / 2 <= reach

    return {"sample-pose": from_fn(sample_pose), "test-reachable": from_test(reachable)}


DOMAIN = DomainSpec(
    name="holdline",
    description="the line domain, held while a file exists (a test domain)",
    problem_from_scene=problem_from_scene,
    bindings=bindings,
)
'''


def _hold_domain(tmp_path: Path) -> tuple[Path, Path]:
    """The domain's folder with one scene; (the scene file, the hold file, created)."""
    folder = tmp_path / "holdline"
    (folder / "scenes").mkdir(parents=True)
    for name in ("domain.pddl", "stream.pddl"):
        shutil.copy(LINE / name, folder / name)
    (folder / "domain.py").write_text(HOLD_DOMAIN)
    scene = json.loads((Path(__file__).parent / "search" / "line-reach.json").read_text())
    scene.update(name="hold-2", domain="..")
    (folder / "scenes" / "hold-2.json").write_text(json.dumps(scene))
    hold = folder / "hold"
    hold.touch()
    return folder / "scenes" / "hold-2.json", hold


@pytest.fixture(scope="module")
def cluster() -> Iterator[Any]:
    """A head node that runs no trial (the driver's) and two worker nodes of one CPU each."""
    from ray.cluster_utils import Cluster

    patch = pytest.MonkeyPatch()
    patch.setenv("RAY_AUTH_MODE", "disabled")
    patch.setenv("RAY_USAGE_STATS_ENABLED", "0")
    patch.setenv("RAY_worker_niceness", "0")  # trials timed like the process pool's
    # Ray's socket paths under its folder must fit in 107 bytes: a folder of /tmp, not pytest's
    # (deeper still under pytest -n, .../popen-gw0/...).
    temp = tempfile.mkdtemp(prefix="ray-")
    cluster = Cluster(
        initialize_head=True,
        head_node_args={"num_cpus": 0, "include_dashboard": False, "temp_dir": temp},
    )
    try:
        cluster.add_node(num_cpus=1)
        cluster.add_node(num_cpus=1)
        cluster.wait_for_nodes()
        yield cluster
    finally:
        cluster.shutdown()
        patch.undo()
        shutil.rmtree(temp, ignore_errors=True)


def _wait(what: str, ready: Callable[[], bool], timeout: float = 180.0) -> None:
    deadline = time.monotonic() + timeout
    while not ready():
        if time.monotonic() > deadline:
            raise AssertionError(f"still waiting for {what} after {timeout:.0f} s")
        time.sleep(0.25)


@pytest.mark.slow
def test_a_node_that_dies_crashes_its_trial_and_resume_completes_the_benchmark(
    cluster: Any, postgres: PostgresServer, tmp_path: Path
) -> None:
    scene, hold = _hold_domain(tmp_path)
    db = postgres.new_database("cluster")
    config = make_config(str(scene), ["baseline"], trials=3, seed_start=0, budget_s=120.0)
    outcome: dict[str, tuple[str, list[TrialResult]]] = {}
    failure: list[BaseException] = []

    def benchmark() -> None:
        try:
            outcome["first"] = run_bench(db, config, workers=2, ray_address=cluster.address)
        except BaseException as exc:
            failure.append(exc)

    driver = threading.Thread(target=benchmark)
    driver.start()
    try:
        with RunStore(db) as store:
            # Both worker nodes run a trial, held in its first pose query.
            _wait("a trial on each node", lambda: store.count_runs(status="running") == 2)
            doomed = [n for n in cluster.worker_nodes][-1]
            doomed_id = doomed.node_id
            cluster.remove_node(doomed, allow_graceful=False)  # kills its raylet and workers
            (bench,) = store.list_benches()
            _wait(
                "the dead node's trial to crash",
                lambda: any(t.status == "crashed" for t in store.bench_trials(bench.id)),
            )
    finally:
        hold.unlink()  # the other trials finish
        driver.join(timeout=300)
    assert not failure, failure
    bench_id, first = outcome["first"]
    assert len(first) == 3
    (crashed,) = [r for r in first if r.status == "crashed"]
    assert crashed.error is not None and crashed.error.startswith("the Ray task failed: ")
    # Ray's reason: the node died, named by its id (or, had Ray seen its worker go first, the
    # worker did, and Ray's reason names no node).
    if "NodeDiedError" in crashed.error:
        assert f"node ID: {doomed_id}" in crashed.error, crashed.error
    else:
        assert "WorkerCrashedError" in crashed.error, crashed.error
    assert sorted(r.status for r in first if r is not crashed) == ["solved", "solved"]

    with RunStore(db) as store:
        assert store.get_bench(bench_id).status == "done"
        (stored,) = [t for t in store.bench_trials(bench_id) if t.status == "crashed"]
        assert stored.seed == crashed.trial.seed and stored.error == crashed.error
        assert crashed.run_id is not None  # its run had begun on the dead node: finished too
        dead_run = store.get_run(crashed.run_id)
        assert dead_run.status == "failed" and dead_run.message.startswith("crashed: ")

    # The dead node stays dead: the remaining node runs the crashed trial again.
    again_id, again = run_bench(db, resume=bench_id, workers=2, ray_address=cluster.address)
    assert again_id == bench_id
    assert [(r.trial.seed, r.status) for r in again] == [(crashed.trial.seed, "solved")]
    with RunStore(db) as store:
        trials = store.bench_trials(bench_id)
        assert [(t.seed, t.planner, t.status) for t in trials] == [
            (seed, "baseline", "solved") for seed in (0, 1, 2)
        ]  # every seed's trial once, none crashed
        for t in trials:
            assert t.run_id is not None and store.get_run(t.run_id).status == "solved"
            assert store.events(t.run_id)[-1].type == "run_finished"
        assert store.count_runs() == 4  # three solved and the dead node's failed run
