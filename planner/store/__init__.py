"""The record of runs: every event and every stream query, in SQLite through SQLAlchemy."""

from planner.store.db import (
    BENCH_STATUSES,
    FINAL_STATUSES,
    LIVE_STATUSES,
    MAX_INT,
    RUN_STATUSES,
    BenchRecord,
    BenchTrialRecord,
    QueryOutcome,
    QueryRecord,
    RunRecord,
    RunStore,
    StoreSink,
    default_db_path,
)
from planner.store.owner import is_alive, process_token

__all__ = [
    "BENCH_STATUSES",
    "FINAL_STATUSES",
    "LIVE_STATUSES",
    "MAX_INT",
    "RUN_STATUSES",
    "BenchRecord",
    "BenchTrialRecord",
    "QueryOutcome",
    "QueryRecord",
    "RunRecord",
    "RunStore",
    "StoreSink",
    "default_db_path",
    "is_alive",
    "process_token",
]
