"""The model registry from the command line: one database session around a :class:`ModelService`.

Used by ``cavewalk models list|register|activate|rollback`` and ``cavewalk train`` (which registers
the model it writes). A server running on the same database builds its pipeline with a model
activated here at the pipeline's next start.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from app.core.config import Settings
from app.db.errors import RecordNotFound, StateConflict
from pipeline.errors import CavewalkError, ConfigError

if TYPE_CHECKING:
    from app.services.models import ModelService


@contextmanager
def open_registry(settings: Settings, db: Path | None = None) -> Iterator[ModelService]:
    """The registry of the database ``db`` (default: the settings' ``paths.db``), migrated first."""
    # SQLAlchemy is imported when a command opens the registry, not at the top: cavewalk's start-up time
    from app.db.engine import make_engine, make_session_factory
    from app.db.migrate import prepare_database, upgrade
    from app.services.backup import backup_before_upgrade
    from app.services.event_log import EventWriter
    from app.services.models import ModelService

    path = (db or settings.paths.db).expanduser()
    if path.exists() and path.is_dir():
        raise ConfigError(f"--db {path} is a folder, not a database file")
    path.parent.mkdir(parents=True, exist_ok=True)
    backup_before_upgrade(path, settings.backup)  # an older cavewalk's database: copied first
    prepare_database(path)
    if db is not None:
        settings = settings.model_copy(update={"paths": settings.paths.model_copy(update={"db": path})})
    engine = make_engine(path)
    try:
        upgrade(engine)
        factory = make_session_factory(engine)
        events = EventWriter(factory, settings.event_log)
        try:
            yield ModelService(settings, factory, events)
        except (RecordNotFound, StateConflict) as exc:  # one error: line, as every user error
            raise CavewalkError(str(exc)) from None
        finally:
            events.close()
    finally:
        engine.dispose()
