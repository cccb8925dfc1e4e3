"""Every status name, in one place: of a run, of what a planner's search ended with, of a
benchmark, of a training job.

The store, the events, the planners, the REST schemas and the page (through
``/generated/definitions.js``, made by :func:`planner.figures.definitions`) all take their names
from here. Each set is a ``Literal`` type, so mypy checks every literal compared with a typed
status, and a tuple of the same names, in order, for the code that lists or validates them.
The names are the wire format: stored runs and events keep them as text.
"""

from __future__ import annotations

from typing import Literal, TypeAlias, get_args

# --- runs --------------------------------------------------------------------------------------

# A run waits for a worker, plans, then ends in one of the final five.
RunStatus: TypeAlias = Literal[
    "queued", "running", "solved", "failed", "timeout", "cancelled", "interrupted"
]
RUN_STATUSES: tuple[RunStatus, ...] = get_args(RunStatus)
LiveStatus: TypeAlias = Literal["queued", "running"]
LIVE_STATUSES: tuple[LiveStatus, ...] = get_args(LiveStatus)  # not finished yet
FINAL_STATUSES: tuple[RunStatus, ...] = tuple(s for s in RUN_STATUSES if s not in LIVE_STATUSES)

# What a planner's search ends with (planner.planners.PlannerOutcome, the tree search's result).
SearchStatus: TypeAlias = Literal["solved", "timeout", "failed", "cancelled"]
SEARCH_STATUSES: tuple[SearchStatus, ...] = get_args(SearchStatus)

# What a run_finished event says (a cancelled run ends with run_cancelled instead): the
# search's status, or failed when its plan does not validate.
FinishStatus: TypeAlias = Literal["solved", "failed", "timeout"]
FINISH_STATUSES: tuple[FinishStatus, ...] = get_args(FinishStatus)

STATUS_TEXT: dict[RunStatus, str] = {
    "queued": "waiting for a worker",
    "running": "planning now",
    "solved": "found a plan within its budget",
    "failed": "stopped on an error, or its plan did not validate",
    "timeout": "no plan within its budget",
    "cancelled": "cancelled by a user, or stopped by the server's shutdown",
    "interrupted": "its process stopped before it finished",
}

# --- benchmarks and training jobs ----------------------------------------------------------------

# A benchmark runs, is done, stopped before its end (resumable), or was cancelled by its user
# (resumable too).
BenchStatus: TypeAlias = Literal["running", "done", "interrupted", "cancelled"]
BENCH_STATUSES: tuple[BenchStatus, ...] = get_args(BenchStatus)

# How a benchmark trial ended: its run's final status, or crashed (its process or Ray node
# died: not an outcome of the planner, run again on resume).
TrialStatus: TypeAlias = Literal["solved", "timeout", "failed", "crashed"]
TRIAL_STATUSES: tuple[TrialStatus, ...] = get_args(TrialStatus)
CRASHED: TrialStatus = "crashed"

TrainStatus: TypeAlias = Literal["running", "done", "failed"]  # a training job of the dashboard
TRAIN_STATUSES: tuple[TrainStatus, ...] = get_args(TrainStatus)


def _check() -> None:
    if not set(SEARCH_STATUSES) <= set(RUN_STATUSES) or not set(FINISH_STATUSES) <= set(
        SEARCH_STATUSES
    ):
        raise RuntimeError("planner.status: a search or finish status that is no run status")
    if tuple(STATUS_TEXT) != RUN_STATUSES:
        raise RuntimeError("planner.status: a run status without its line, or out of order")


_check()


def all_status_names() -> tuple[str, ...]:
    """Every status name of any set, once each, in the order first listed."""
    names: dict[str, None] = {}
    for group in (RUN_STATUSES, BENCH_STATUSES, TRIAL_STATUSES, TRAIN_STATUSES):
        names.update(dict.fromkeys(group))
    return tuple(names)
