"""Apply the Alembic migrations of ``migrations/`` (the app does this on start-up)."""

from __future__ import annotations

import logging
from pathlib import Path

from alembic import command
from alembic.config import Config
from alembic.runtime.migration import MigrationContext
from alembic.script import ScriptDirectory
from sqlalchemy import Engine
from sqlalchemy.exc import SQLAlchemyError

from app.db.engine import connect_read_only, make_engine, table_names
from pipeline.errors import ConfigError

log = logging.getLogger(__name__)

ROOT = Path(__file__).resolve().parents[2]
ALEMBIC_INI = ROOT / "alembic.ini"
MIGRATIONS = ROOT / "migrations"


def alembic_config() -> Config:
    cfg = Config(str(ALEMBIC_INI)) if ALEMBIC_INI.is_file() else Config()
    cfg.set_main_option("script_location", str(MIGRATIONS))
    return cfg


def head_revision() -> str:
    head = ScriptDirectory.from_config(alembic_config()).get_current_head()
    if head is None:
        raise RuntimeError("no Alembic migrations found")
    return head


def known_revisions() -> set[str]:
    """Every revision of ``migrations/`` (a database at another one was made by a newer cavewalk)."""
    return {r.revision for r in ScriptDirectory.from_config(alembic_config()).walk_revisions()}


def current_revision(engine: Engine) -> str | None:
    with engine.connect() as conn:
        return MigrationContext.configure(conn).get_current_revision()


def upgrade(engine: Engine, revision: str = "head") -> None:
    """Upgrade the database of ``engine`` in place to ``revision`` (default: the newest)."""
    cfg = alembic_config()
    before = current_revision(engine)
    with engine.begin() as conn:
        cfg.attributes["connection"] = conn
        command.upgrade(cfg, revision)
    after = current_revision(engine)
    if before != after:
        log.info("database migrated from %s to %s", before or "empty", after)


def _foreign_tables(db_path: Path) -> list[str]:
    """The tables of an existing database file that has no Alembic revision (another program's
    database). Read through a read-only connection: opening it with the app's engine would
    already switch its journal to WAL, which writes to the file."""
    import sqlite3

    if not db_path.is_file() or db_path.stat().st_size == 0:
        return []
    try:
        con = connect_read_only(db_path)
    except sqlite3.Error:
        return []
    try:
        names = table_names(con)
    except sqlite3.Error:
        return []  # not a database: the engine says so below
    finally:
        con.close()
    if "alembic_version" in names:
        return []
    return sorted(n for n in names if not n.startswith("sqlite_"))


def _check_writable(engine: Engine) -> None:
    """Write the database header (its user_version, unchanged) in a transaction rolled back: a
    read-only file passes a migration that has nothing to do and fails at the first real write."""
    with engine.connect() as conn:
        conn.exec_driver_sql("BEGIN IMMEDIATE")
        try:
            version = conn.exec_driver_sql("PRAGMA user_version").scalar()
            conn.exec_driver_sql(f"PRAGMA user_version = {int(version or 0)}")
        finally:
            conn.exec_driver_sql("ROLLBACK")


def prepare_database(db_path: Path) -> None:
    """Create or upgrade the database file in place; ConfigError with the reason when it cannot be used."""
    if db_path.is_dir():
        raise ConfigError(f"database {db_path} is a folder, not a file")
    foreign = _foreign_tables(db_path)
    if foreign:
        raise ConfigError(f"database {db_path} is not a cavewalk database (it has the tables "
                          f"{', '.join(foreign[:5])} and no cavewalk revision); give another --db")
    engine = make_engine(db_path)
    try:
        upgrade(engine)
        _check_writable(engine)  # a read-only file or folder is found here, not mid-session
    except ConfigError:
        raise
    except SQLAlchemyError as exc:
        reason = str(getattr(exc, "orig", None) or exc).splitlines()[0]
        raise ConfigError(f"database {db_path} cannot be used: {reason}") from exc
    except Exception as exc:  # alembic: an unknown revision (a newer cavewalk's database)
        raise ConfigError(f"database {db_path} cannot be migrated: {exc}") from exc
    finally:
        engine.dispose()
