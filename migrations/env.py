"""Alembic environment of cavewalk.

The app passes an open connection in ``config.attributes["connection"]``
(see :func:`app.db.migrate.upgrade_to_head`); from the command line the database
path comes from ``-x db=PATH`` or the settings.
"""

from __future__ import annotations

from logging.config import fileConfig

from alembic import context
from sqlalchemy import Connection, create_engine

from app.db.models import Base

config = context.config
target_metadata = Base.metadata


def _run(connection: Connection) -> None:
    context.configure(connection=connection, target_metadata=target_metadata, render_as_batch=True)
    with context.begin_transaction():
        context.run_migrations()


def run_migrations_online() -> None:
    connection = config.attributes.get("connection")
    if connection is not None:
        _run(connection)
        return
    if config.config_file_name is not None:
        fileConfig(config.config_file_name, disable_existing_loggers=False)
    db = context.get_x_argument(as_dictionary=True).get("db")
    if db is None:
        from app.core.config import get_settings

        db = str(get_settings().paths.db)
    engine = create_engine(f"sqlite:///{db}")
    with engine.connect() as conn:
        _run(conn)
    engine.dispose()


def run_migrations_offline() -> None:
    context.configure(
        url="sqlite://", target_metadata=target_metadata, literal_binds=True, render_as_batch=True
    )
    with context.begin_transaction():
        context.run_migrations()


if context.is_offline_mode():
    run_migrations_offline()
else:
    run_migrations_online()
