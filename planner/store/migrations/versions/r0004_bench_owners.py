"""benchmarks.owner: the process running a benchmark.

Revision ID: 0004
Revises: 0003
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from planner.store.migrations import add_missing_column

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None


def upgrade() -> None:
    add_missing_column("benchmarks", sa.Column("owner", sa.Text))


def downgrade() -> None:
    op.drop_column("benchmarks", "owner")
