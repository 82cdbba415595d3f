"""The server's log file: every process of a running server appends its log lines to one file.

The web app's process (``cavewalk serve`` / ``demo``) and the pipeline's worker processes write
their log records to ``LogFileConfig.path`` as well as to stderr, so that a study day's log is
still there after the terminal has scrolled or closed. The app's process alone starts a new
file when the file passes ``max_mb`` (the old ones become ``cavewalk.log.1`` ... ``.keep``); a
worker reopens the file when it was renamed (:class:`logging.handlers.WatchedFileHandler`), so
no process keeps writing into a file that was rotated away. Every process opens the file for
appending and writes a record at once, so records of several processes follow each other whole
(a record longer than the write buffer, 8 KiB, may be cut by another's).
"""

from __future__ import annotations

import logging
import logging.handlers
import sys
from dataclasses import dataclass
from pathlib import Path

__all__ = ["LOG_FORMAT", "LogFileConfig", "log_to_file", "to_log_file_only"]

#: One format for every cavewalk process (stderr and the log file).
LOG_FORMAT = "%(asctime)s %(levelname)-7s %(processName)s %(name)s: %(message)s"
_FILE_DATEFMT = "%Y-%m-%d %H:%M:%S"  # a study day's file spans days: the date too


@dataclass(frozen=True, slots=True)
class LogFileConfig:
    """The server's log file (``[runtime.log]``).

    enabled: write the log file at all.
    path: the file; None: ``logs/cavewalk.log`` beside the database (``cavewalk serve`` and ``demo``
        set it; a pipeline without a path writes no file).
    max_mb: the app's process starts a new file once the file is this large (MB).
    keep: this many old files are kept (``path.1`` is the newest).
    """

    enabled: bool = True
    path: Path | None = None
    max_mb: float = 20.0
    keep: int = 5

    def __post_init__(self) -> None:
        if not self.max_mb > 0:
            raise ValueError(f"max_mb must be > 0, got {self.max_mb}")
        if not 1 <= self.keep <= 100:
            raise ValueError(f"keep must be 1..100, got {self.keep}")

    @property
    def active(self) -> bool:
        """A file is written: enabled, with a path."""
        return self.enabled and self.path is not None


class _SaysOnce(logging.FileHandler):
    """A record it cannot write (a full disk) is one line on stderr, not a traceback per record;
    another when it writes again."""

    _failing = False
    _failed_now = False

    def emit(self, record: logging.LogRecord) -> None:
        self._failed_now = False
        super().emit(record)
        if self._failing and not self._failed_now:
            self._failing = False
            sys.stderr.write(f"cavewalk: the log file {self.baseFilename} is written again\n")

    def handleError(self, record: logging.LogRecord) -> None:
        self._failed_now = True
        if not self._failing:
            self._failing = True
            sys.stderr.write(f"cavewalk: cannot write the log file {self.baseFilename}: {sys.exc_info()[1]} "
                             "(the log goes to the terminal only until it can)\n")

    def close(self) -> None:
        try:
            super().close()
        except OSError:  # records it could not write are lost with the file that could not take them
            self.stream = None  # type: ignore[assignment]


class _Rotating(_SaysOnce, logging.handlers.RotatingFileHandler):
    pass


class _Watched(_SaysOnce, logging.handlers.WatchedFileHandler):
    pass


def log_to_file(config: LogFileConfig, *, rotate: bool) -> Path | None:
    """Add the log file to the root logger of this process (once; again for another path).

    rotate: this process starts new files (the app's process); the others only reopen a file that
    was rotated away (the workers). Returns the file, or None when ``config`` writes none.
    OSError when the file cannot be opened (a folder that cannot be made, no permission)."""
    if not config.active or config.path is None:
        return None
    path = config.path.expanduser().resolve()
    root = logging.getLogger()
    for h in list(root.handlers):
        mine = getattr(h, "_cavewalk_file", None)
        if mine is not None:
            if mine == path:
                return path
            root.removeHandler(h)
            h.close()
    path.parent.mkdir(parents=True, exist_ok=True)
    handler: logging.FileHandler
    if rotate:
        handler = _Rotating(path, maxBytes=int(config.max_mb * 1_000_000), backupCount=config.keep,
                            encoding="utf-8")
    else:
        handler = _Watched(path, encoding="utf-8")
    handler.setFormatter(logging.Formatter(LOG_FORMAT, datefmt=_FILE_DATEFMT))
    setattr(handler, "_cavewalk_file", path)  # noqa: B010 (found again above)
    root.addHandler(handler)
    return path


def to_log_file_only(level: int, message: str, name: str = "cavewalk") -> bool:
    """One record for this process's log file, not for the terminal (which has just been told the
    same in its own words: the ``error:`` line of a server that did not start). False when no log
    file is open."""
    root = logging.getLogger()
    files = [h for h in root.handlers if getattr(h, "_cavewalk_file", None) is not None]
    record = logging.getLogger(name).makeRecord(name, level, __file__, 0, message, (), None)
    for h in files:
        h.handle(record)
    return bool(files)
