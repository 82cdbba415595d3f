"""``cavewalk db backup|backups|restore``: the study database's backups (the server makes its own too,
see :mod:`app.services.backup`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from app.core.config import get_settings

if TYPE_CHECKING:
    from app.db.backup import BackupInfo

app = typer.Typer(name="db", help="The study database: backups and restore.", no_args_is_help=True)

DbOption = Annotated[
    Path | None, typer.Option("--db", help="SQLite database (default: the settings' paths.db).")
]


def _paths(db: Path | None) -> tuple[Path, Path]:
    # app.db.backup (SQLAlchemy, alembic) is imported where it is used: cavewalk's start-up time
    from app.db.backup import backup_folder

    settings = get_settings()
    path = (db or settings.paths.db).expanduser()
    return path, backup_folder(path, settings.backup.folder)


def _counts(info: BackupInfo) -> str:
    c = info.counts
    return (
        f"{c.get('participants', 0)} participants, {c.get('study_sessions', 0)} sessions, "
        f"{c.get('questionnaire_responses', 0)} questionnaires, {c.get('events', 0)} events, "
        f"{c.get('takes', 0)} takes"
    )


@app.command("backup")
def backup_cmd(
    db: DbOption = None,
    out: Annotated[
        Path | None,
        typer.Option("--out", help="The backup file to write; must not exist (default: the backup folder)."),
    ] = None,
) -> None:
    """A checked copy of the database, also while the server uses it (it goes on writing)."""
    from app.db.backup import backup_database, new_backup_path, prune_backups

    path, folder = _paths(db)
    target = out.expanduser() if out is not None else new_backup_path(folder, path, "manual")
    info = backup_database(path, target)
    typer.echo(
        f"backed up {path} to {info.path} ({info.size_bytes} bytes, revision {info.revision}): "
        f"{_counts(info)}"
    )
    if out is None:
        removed = prune_backups(folder, path, get_settings().backup.keep)
        if removed:
            typer.echo(f"removed {len(removed)} older backup(s) (backup.keep = {get_settings().backup.keep})")


@app.command("backups")
def backups_cmd(db: DbOption = None) -> None:
    """The database's backups in the backup folder, newest first."""
    from app.db.backup import list_backups

    path, folder = _paths(db)
    found = list_backups(folder, path)
    if not found:
        typer.echo(f"no backups of {path} in {folder}")
        return
    typer.echo(f"{len(found)} backup(s) of {path} in {folder}, newest first:")
    for b in found:
        typer.echo(
            f"  {b.path.name}  {b.created:%Y-%m-%d %H:%M:%S} UTC  {b.reason:<14} {b.size_bytes:>12} bytes"
        )


@app.command("restore")
def restore_cmd(
    backup: Annotated[Path, typer.Argument(help="The backup file (a path, or a name in the backup folder).")],
    db: DbOption = None,
) -> None:
    """Put a backup in place of the database (no server may be using it). A damaged, foreign or newer
    backup is refused before anything changes; the database it replaces is kept first."""
    from app.db.backup import BackupError, restore_database

    path, folder = _paths(db)
    source = backup.expanduser()
    if not source.is_file() and not source.is_absolute() and (folder / backup).is_file():
        source = folder / backup
    if not source.is_file():
        raise BackupError(f"backup not found: {backup}")
    if source.resolve() == path.resolve():
        raise BackupError(f"{backup} is the database itself")
    safety, restored = restore_database(source, path, folder)
    if safety is not None:
        typer.echo(f"the replaced database is kept as {safety.path}")
    typer.echo(f"restored {source} into {path} (revision {restored.revision}): {_counts(restored)}")
