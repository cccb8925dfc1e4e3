"""No process outlives the one that started it: trials end with a killed ``tamp bench``, and a
planner binary (a process group of its own) ends with the trial that ran it."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from planner import supervise
from planner.store import RunStore

pytestmark = pytest.mark.slow

LINE = Path(__file__).parent / "search" / "line-reach.json"
# Waits on states, bounded so that a broken supervisor fails the test rather than hangs it;
# how fast processes go is measured in docs/BENCHMARKS.md, not asserted here.
WAIT_S = 120.0


def _never(tmp_path: Path) -> Path:
    """A scene no sampled pose solves (the gripper reaches nothing): its trials plan until
    their budget, so they are still planning when their benchmark is killed."""
    scene = json.loads(LINE.read_text(encoding="utf-8"))
    scene.update(name="line-never", reach=-10.0)
    path = tmp_path / "line-never.json"
    path.write_text(json.dumps(scene), encoding="utf-8")
    return path


def _children(pid: int) -> list[int]:
    """The processes whose parent is ``pid``."""
    out = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
            out.append(int(entry.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")


def _wait_until(what: str, ready: object) -> None:
    deadline = time.monotonic() + WAIT_S
    while not ready():  # type: ignore[operator]
        if time.monotonic() > deadline:
            raise AssertionError(f"not within {WAIT_S:.0f} s: {what}")
        time.sleep(0.1)


def test_kill_9_of_tamp_bench_leaves_no_trial_planning(tmp_path: Path) -> None:
    db = tmp_path / "k.db"
    scene = _never(tmp_path)
    bench = subprocess.Popen(
        [
            *(sys.executable, "-m", "planner.cli", "bench", "--scene", str(scene), "--db", str(db)),
            *("--planners", "baseline", "--trials", "4", "--budget", "3000", "--workers", "2"),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:

        def two_planning() -> bool:
            if not db.exists():
                return False
            with RunStore(db) as store:
                return store.count_runs(status="running") == 2

        _wait_until("two trials planning", two_planning)
        trials = _children(bench.pid)
        assert len(trials) >= 2, trials
        bench.kill()  # SIGKILL: nothing in tamp bench runs after it
        bench.wait(timeout=30)
        _wait_until(
            f"the trial processes {trials} gone", lambda: not any(_alive(p) for p in trials)
        )
    finally:
        if bench.poll() is None:
            bench.kill()
        for pid in _children(bench.pid):
            os.kill(pid, signal.SIGKILL)
    # The killed trials' runs are finished as interrupted when the benchmark resumes.
    with RunStore(db) as store:
        (record,) = store.list_benches()
        assert store.count_runs(status="running") == 2  # nobody finished them yet
        assert store.mark_interrupted() == 2
        assert store.count_runs(status="interrupted") == 2
        assert record.status == "running"
        assert store.settle_benches() == 1


def _planner_binary_then_block(marker: str) -> None:
    """A child that starts a process group of its own (as Fast Downward is run) and waits on
    it; the group's leader writes its pid to ``marker`` once it runs."""
    supervise.run_group(
        ["sh", "-c", f'echo $$ > "{marker}"; exec sleep 3000'], Path(marker).parent, 3000.0
    )


def test_a_planner_binary_ends_with_the_process_that_ran_it(tmp_path: Path) -> None:
    """Its parent is killed with SIGKILL: the child (a trial) ends, and so does the group it
    started in a session of its own, which no signal to the child's group would reach."""
    marker = tmp_path / "binary.pid"
    script = (
        "import time\n"
        "from planner import supervise\n"
        "from tests.test_supervise import _planner_binary_then_block\n"
        "if __name__ == '__main__':\n"
        f"    p = supervise.spawn(_planner_binary_then_block, {str(marker)!r})\n"
        "    print(p.pid, flush=True)\n"
        "    time.sleep(3000)\n"
    )
    root = Path(__file__).resolve().parents[1]
    parent = subprocess.Popen(
        [sys.executable, "-c", script],
        cwd=root,
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(root)},
    )
    binary = 0
    try:
        assert parent.stdout is not None
        child = int(parent.stdout.readline())
        _wait_until("the binary running", lambda: marker.exists() and marker.read_text().strip())
        binary = int(marker.read_text())
        assert _alive(child) and _alive(binary)
        parent.kill()
        parent.wait(timeout=30)
        _wait_until("the child gone", lambda: not _alive(child))
        _wait_until("the planner binary gone", lambda: not _alive(binary))
    finally:
        if parent.poll() is None:
            parent.kill()
        if binary and _alive(binary):
            os.killpg(binary, signal.SIGKILL)


def test_sigterm_to_a_child_ends_its_planner_binaries(tmp_path: Path) -> None:
    """A parent stops a child with SIGTERM (a cancelled run, an interrupted benchmark's
    trials): the binaries the child runs go with it."""
    marker = tmp_path / "binary.pid"
    child = supervise.spawn(_planner_binary_then_block, str(marker))
    binary = 0
    try:
        _wait_until("the binary running", lambda: marker.exists() and marker.read_text().strip())
        binary = int(marker.read_text())
        child.terminate()
        child.join(timeout=WAIT_S)
        assert child.exitcode == -signal.SIGTERM
        _wait_until("the planner binary gone", lambda: not _alive(binary))
    finally:
        if child.is_alive():
            child.kill()
        if binary and _alive(binary):
            os.killpg(binary, signal.SIGKILL)


def test_kill_groups_stops_what_run_group_runs(tmp_path: Path) -> None:
    errors: list[BaseException] = []

    def run() -> None:
        try:
            supervise.run_group(["sleep", "3000"], tmp_path, 3000.0)
        except BaseException as exc:  # the test reads it
            errors.append(exc)

    thread = threading.Thread(target=run)
    thread.start()
    _wait_until("the group running", lambda: bool(supervise.running_groups()))
    (group,) = supervise.running_groups()
    assert supervise.kill_groups() == 1
    thread.join(timeout=WAIT_S)
    assert not thread.is_alive() and not errors  # it ended (killed), and said so by its code
    assert not _alive(group) and supervise.running_groups() == []


def test_kill_groups_finds_a_group_not_tracked_yet() -> None:
    """SIGTERM handled between Popen's return and the group's tracking: the child leading a
    session of its own is found all the same (this race once left a binary running)."""
    binary = subprocess.Popen(["sleep", "3000"], start_new_session=True)
    try:
        assert binary.pid not in supervise.running_groups()
        assert supervise.kill_groups() >= 1
        assert binary.wait(timeout=WAIT_S) == -signal.SIGKILL
    finally:
        if binary.poll() is None:
            binary.kill()
