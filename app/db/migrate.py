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

from app.db.engine import make_engine
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


def prepare_database(db_path: Path) -> None:
    """Create or upgrade the database file in place; ConfigError with the reason when it cannot be used."""
    if db_path.is_dir():
        raise ConfigError(f"database {db_path} is a folder, not a file")
    engine = make_engine(db_path)
    try:
        upgrade(engine)
    except SQLAlchemyError as exc:
        reason = str(getattr(exc, "orig", None) or exc).splitlines()[0]
        raise ConfigError(f"database {db_path} cannot be used: {reason}") from exc
    except Exception as exc:  # alembic: an unknown revision (a newer cavewalk's database)
        raise ConfigError(f"database {db_path} cannot be migrated: {exc}") from exc
    finally:
        engine.dispose()
