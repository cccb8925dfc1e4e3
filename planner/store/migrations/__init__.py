"""The run store's schema history as Alembic revisions (``versions/``), applied by
:func:`planner.store.schema.upgrade` whenever a store is opened.

Stores written before the schema had versions (no ``alembic_version`` table) are upgraded from
the first revision like a new one: each revision creates only the tables, columns and indices
that are missing, so such a store ends at the head with its rows kept.
"""

from __future__ import annotations

import logging

import sqlalchemy as sa
from alembic import op

log = logging.getLogger(__name__)


def has_column(table: str, column: str) -> bool:
    return column in {c["name"] for c in sa.inspect(op.get_bind()).get_columns(table)}


def add_missing_column(table: str, column: sa.Column[object]) -> None:
    """``ALTER TABLE ... ADD COLUMN`` unless a store from before versions has it already."""
    if has_column(table, column.name):
        log.debug("run store: %s.%s is there already", table, column.name)
        return
    op.add_column(table, column)
    log.info("run store: added column %s.%s", table, column.name)
