"""runs.owner and an index on runs.created_at.

The owner is the process running a live run; the index lists runs newest first.

Revision ID: 0003
Revises: 0002
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from planner.store.migrations import add_missing_column

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    add_missing_column("runs", sa.Column("owner", sa.Text))
    op.create_index("ix_runs_created_at", "runs", ["created_at"], if_not_exists=True)


def downgrade() -> None:
    op.drop_index("ix_runs_created_at", "runs")
    op.drop_column("runs", "owner")
