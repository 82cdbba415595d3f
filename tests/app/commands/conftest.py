"""Shared by the command-line tests: the real entry point with arguments, and settings reset after
each test (a command loads them from the environment it runs in)."""

from __future__ import annotations

import sys
from collections.abc import Iterator

import pytest

from app.cli import main
from app.core.config import set_settings


@pytest.fixture(autouse=True)
def _reset_settings() -> Iterator[None]:
    yield
    set_settings(None)


def run_cli(monkeypatch: pytest.MonkeyPatch, *args: str) -> int:
    """``cavewalk ARGS`` through :func:`app.cli.main`; its exit code."""
    monkeypatch.setattr(sys, "argv", ["cavewalk", *args])
    try:
        main()
    except SystemExit as exc:
        return int(exc.code or 0)
    return 0
