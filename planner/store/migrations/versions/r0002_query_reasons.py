"""stream_queries.reason: why a sampler that ran cleanly found nothing (2026-11-24).

Revision ID: 0002
Revises: 0001
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from planner.store.migrations import add_missing_column

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None


def upgrade() -> None:
    add_missing_column("stream_queries", sa.Column("reason", sa.Text))


def downgrade() -> None:
    op.drop_column("stream_queries", "reason")
