"""Baseline: runs, events, stream queries, benchmarks and their trials.

The schema of the first stores with benchmarks (2026-11). The stores before those lack the
benchmark tables, and the very first ones ``stream_queries.context``: they get them here.

Revision ID: 0001
Revises:
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from planner.store.migrations import add_missing_column

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "runs",
        sa.Column("id", sa.String(32), primary_key=True),
        sa.Column("scene", sa.Text, nullable=False),
        sa.Column("seed", sa.Integer, nullable=False),
        sa.Column("planner", sa.String(100), nullable=False),
        sa.Column("config", sa.Text, nullable=False),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("finished_at", sa.DateTime(timezone=True)),
        sa.Column("planning_s", sa.Double),
        sa.Column("execution_s", sa.Double),
        sa.Column("oracle_s", sa.Double),
        sa.Column("queries", sa.Integer, nullable=False),
        sa.Column("message", sa.Text, nullable=False),
        sa.Column("plan", sa.Text),
        if_not_exists=True,
    )
    op.create_table(
        "events",
        sa.Column(
            "run_id",
            sa.String(32),
            sa.ForeignKey("runs.id", ondelete="CASCADE"),
            primary_key=True,
        ),
        sa.Column("seq", sa.Integer, primary_key=True),
        sa.Column("t", sa.Double, nullable=False),
        sa.Column("type", sa.String(32), nullable=False),
        sa.Column("payload", sa.Text, nullable=False),
        if_not_exists=True,
    )
    op.create_table(
        "stream_queries",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column(
            "run_id", sa.String(32), sa.ForeignKey("runs.id", ondelete="CASCADE"), nullable=False
        ),
        sa.Column("node_id", sa.Integer, nullable=False),
        sa.Column("seq", sa.Integer, nullable=False),
        sa.Column("stream", sa.String(200), nullable=False),
        sa.Column("input_names", sa.Text, nullable=False),
        sa.Column("inputs", sa.Text, nullable=False),
        sa.Column("success", sa.Boolean, nullable=False),
        sa.Column("wall_s", sa.Double, nullable=False),
        sa.Column("cpu_s", sa.Double, nullable=False),
        sa.Column("execution_s", sa.Double, nullable=False),
        sa.Column("error", sa.Text),
        sa.Column("context", sa.Text, nullable=False),
        if_not_exists=True,
    )
    add_missing_column(
        "stream_queries", sa.Column("context", sa.Text, nullable=False, server_default="{}")
    )
    op.create_index("ix_stream_queries_stream", "stream_queries", ["stream"], if_not_exists=True)
    op.create_index("ix_stream_queries_run_id", "stream_queries", ["run_id"], if_not_exists=True)
    op.create_table(
        "benchmarks",
        sa.Column("id", sa.String(32), primary_key=True),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("finished_at", sa.DateTime(timezone=True)),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("config", sa.Text, nullable=False),
        if_not_exists=True,
    )
    op.create_table(
        "bench_trials",
        sa.Column(
            "bench_id",
            sa.String(32),
            sa.ForeignKey("benchmarks.id", ondelete="CASCADE"),
            primary_key=True,
        ),
        sa.Column("seed", sa.Integer, primary_key=True),
        sa.Column("planner", sa.String(100), primary_key=True),
        sa.Column("run_id", sa.String(32)),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("valid", sa.Boolean),
        sa.Column("planning_s", sa.Double),
        sa.Column("execution_s", sa.Double),
        sa.Column("oracle_s", sa.Double),
        sa.Column("queries", sa.Integer, nullable=False),
        sa.Column("error", sa.Text),
        sa.Column("finished_at", sa.DateTime(timezone=True), nullable=False),
        if_not_exists=True,
    )


def downgrade() -> None:
    for table in ("bench_trials", "benchmarks", "stream_queries", "events", "runs"):
        op.drop_table(table)
