"""What the backup routes answer (:mod:`app.api.routes.backups`)."""

from __future__ import annotations

from datetime import datetime

from pydantic import BaseModel


class BackupPublic(BaseModel):
    name: str  # the file's name in the backup folder
    created: datetime
    reason: str  # manual, start, before-upgrade, session-end, auto, stop, before-restore
    size_bytes: int
    revision: str | None  # the database revision it holds (None: not read, in a listing)
    counts: dict[str, int]  # rows per table (empty in a listing)


class BackupsPublic(BaseModel):
    enabled: bool
    folder: str
    keep: int
    interval_min: float
    last: BackupPublic | None  # the newest this server made (or found unchanged at start)
    last_error: str | None  # the last backup's failure, until one succeeds
    same_disk: bool | None  # the folder is on the database's own disk (None: unknown)
    backups: list[BackupPublic]  # the database's backups in the folder, newest first
