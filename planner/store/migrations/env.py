"""Alembic's entry point: migrations run on the connection :mod:`planner.store.schema` hands
over (``config.attributes["connection"]``), inside the transaction it holds."""

from __future__ import annotations

from alembic import context
from sqlalchemy import Connection

connection = context.config.attributes.get("connection")
if not isinstance(connection, Connection):
    raise RuntimeError(
        "the run store's migrations run through planner.store.schema.upgrade (RunStore opens a "
        "store and upgrades it); offline SQL generation is not supported"
    )
context.configure(connection=connection, target_metadata=None)
with context.begin_transaction():
    context.run_migrations()
