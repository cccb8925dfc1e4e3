"""The record of runs: every event and every stream query, in SQLite or PostgreSQL through
SQLAlchemy, its schema migrated by Alembic when a store opens (``schema``)."""

from planner.status import BENCH_STATUSES, FINAL_STATUSES, LIVE_STATUSES, RUN_STATUSES
from planner.store.db import (
    MAX_INT,
    BenchRecord,
    BenchTrialRecord,
    OutcomeSums,
    QueryOutcome,
    QueryRecord,
    RunRecord,
    RunStore,
    StoreSink,
    default_db_path,
)
from planner.store.owner import is_alive, process_token
from planner.store.schema import SchemaError

__all__ = [
    "BENCH_STATUSES",
    "FINAL_STATUSES",
    "LIVE_STATUSES",
    "MAX_INT",
    "RUN_STATUSES",
    "BenchRecord",
    "BenchTrialRecord",
    "OutcomeSums",
    "QueryOutcome",
    "QueryRecord",
    "RunRecord",
    "RunStore",
    "SchemaError",
    "StoreSink",
    "default_db_path",
    "is_alive",
    "process_token",
]
