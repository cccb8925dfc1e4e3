"""The record of runs: every event and every stream query, in SQLite through SQLAlchemy."""

from planner.store.db import (
    FINAL_STATUSES,
    LIVE_STATUSES,
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

__all__ = [
    "FINAL_STATUSES",
    "LIVE_STATUSES",
    "RUN_STATUSES",
    "BenchRecord",
    "BenchTrialRecord",
    "QueryOutcome",
    "QueryRecord",
    "RunRecord",
    "RunStore",
    "StoreSink",
    "default_db_path",
]
