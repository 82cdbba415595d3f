"""The ``cavewalk`` entry point (``app.cli.main``) run in this process: exit status, stdout, stderr."""

from __future__ import annotations

import logging
import sys

import pytest

from app.cli import main
from app.core.config import set_settings


def run(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, *args: str
) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of ``cavewalk ARGS`` through the real entry point."""
    root = logging.getLogger()
    capsys.readouterr()
    monkeypatch.setattr(sys, "argv", ["cavewalk", *args])
    code = 0
    try:
        main()
    except SystemExit as exc:
        code = int(exc.code or 0) if not isinstance(exc.code, str) else 1
    finally:
        for h in [h for h in root.handlers if getattr(h, "_cavewalk", False)]:
            root.removeHandler(h)
        set_settings(None)
    out, err = capsys.readouterr()
    return code, out, err
