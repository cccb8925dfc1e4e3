"""64-bit integers on PostgreSQL: seeds, sequence numbers, node ids, query counts.

PostgreSQL's INTEGER is 32 bits, SQLite's 64 (nothing changes there). The store accepts any
integer up to 2^63 - 1; a seed past 2^31 failed on PostgreSQL before.

Revision ID: 0005
Revises: 0004
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0005"
down_revision = "0004"
branch_labels = None
depends_on = None

COLUMNS = (
    ("runs", "seed"),
    ("runs", "queries"),
    ("events", "seq"),
    ("stream_queries", "node_id"),
    ("stream_queries", "seq"),
    ("bench_trials", "seed"),
    ("bench_trials", "queries"),
)


def upgrade() -> None:
    if op.get_bind().dialect.name != "postgresql":
        return
    for table, column in COLUMNS:
        op.alter_column(table, column, type_=sa.BigInteger, existing_type=sa.Integer)


def downgrade() -> None:
    if op.get_bind().dialect.name != "postgresql":
        return
    for table, column in COLUMNS:
        op.alter_column(table, column, type_=sa.Integer, existing_type=sa.BigInteger)
