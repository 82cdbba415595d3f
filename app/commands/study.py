"""``cavewalk study report``: figures, tables and a Markdown report of the user study."""

from __future__ import annotations

import sqlite3
from pathlib import Path
from typing import Annotated

import typer

from app.core.config import get_settings
from pipeline.errors import InputError

app = typer.Typer(name="study", help="The user study.", no_args_is_help=True)


def _table_names(path: Path) -> set[str]:
    # the database (SQLAlchemy) and the report (its figures) are imported where used: cavewalk's start-up time
    from app.db.engine import connect_read_only, table_names

    try:
        con = connect_read_only(path)
        try:
            return table_names(con)
        finally:
            con.close()
    except sqlite3.DatabaseError as exc:
        raise InputError(f"{path} is not an SQLite database: {exc}") from exc


@app.command("report")
def report(
    out: Annotated[Path, typer.Option("--out", help="Folder to write the report into.")],
    db: Annotated[
        Path | None, typer.Option("--db", help="SQLite database (default: the settings' paths.db).")
    ] = None,
) -> None:
    """Write the study's figures (PNG + SVG), tables (CSV), analysis.json and report.md into OUT."""
    from app.db.engine import make_engine, make_session_factory
    from app.db.migrate import upgrade
    from app.services.backup import backup_before_upgrade
    from app.study.data import load_study
    from app.study.report import write_report
    from app.study.summary import session_rows

    settings = get_settings()
    path = db or settings.paths.db
    if not path.is_file():
        raise InputError(f"database not found: {path}")
    tables = _table_names(path)  # read-only: a rejected file is left exactly as it was
    if "participants" not in tables:
        raise InputError(f"{path} is not a cavewalk database (no participants table)")
    backup_before_upgrade(path, settings.backup)  # an older cavewalk's database: copied first
    engine = make_engine(path)
    try:
        upgrade(engine)  # an older database is read as the app would: migrated in place first
        with make_session_factory(engine)() as session:
            data = load_study(session)
            sessions = session_rows(session)
    finally:
        engine.dispose()
    typer.echo(
        f"{len(data.participants)} participants, {len(data.sessions)} sessions, "
        f"{len(data.responses)} questionnaires"
    )
    written = write_report(
        data,
        out,
        settings.study.analysis,
        settings.study.design,
        progress=typer.echo,
        sessions=sessions,
    )
    typer.echo(f"report: {out / 'report.md'} ({len(written)} files)")
