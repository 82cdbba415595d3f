"""One log format for every cavewalk process."""

from __future__ import annotations

import logging
import sys
from typing import TextIO

from pipeline.runtime.logfile import LOG_FORMAT

__all__ = ["LOG_FORMAT", "configure_logging"]


class _Stderr(logging.StreamHandler):
    """Writes to whatever ``sys.stderr`` is when a record comes (a test runner swaps it for its own
    stream and closes that afterwards; a handler holding the closed one prints logging errors)."""

    @property
    def stream(self) -> TextIO:
        return sys.stderr

    @stream.setter
    def stream(self, _value: TextIO) -> None:
        pass


def configure_logging(level: int = logging.INFO) -> None:
    """Configure the root logger once (called by the CLI and worker processes, not on import)."""
    root = logging.getLogger()
    if not any(getattr(h, "_cavewalk", False) for h in root.handlers):
        handler = _Stderr()
        handler.setFormatter(logging.Formatter(LOG_FORMAT, datefmt="%H:%M:%S"))
        handler._cavewalk = True  # type: ignore[attr-defined]
        root.addHandler(handler)
    root.setLevel(level)
    # what a user cannot act on: alembic's per-migration INFO lines (app.db.migrate says in one line
    # what was migrated), libraries' chatter
    for noisy in ("matplotlib", "PIL", "httpx", "websockets", "asyncio", "ultralytics", "alembic"):
        logging.getLogger(noisy).setLevel(max(level, logging.WARNING))
