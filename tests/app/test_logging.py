"""The command line's log handler writes to the stderr of the moment, not to one it was given once."""

from __future__ import annotations

import io
import logging
import sys

import pytest

from app.core.logging import configure_logging


def test_records_go_to_the_stderr_of_the_moment(monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """A test runner swaps sys.stderr for its own stream while a command runs and closes it after:
    the records that follow go to the stderr of then, without a logging error about a closed file."""
    root = logging.getLogger()
    before, level = list(root.handlers), root.level
    root.handlers = []
    try:
        swapped = io.StringIO()
        with monkeypatch.context() as m:
            m.setattr(sys, "stderr", swapped)
            configure_logging()
            logging.getLogger("cw.test").warning("while swapped")
        swapped.close()
        logging.getLogger("cw.test").warning("after")
        err = capsys.readouterr().err
        assert "while swapped" not in err and "after" in err, err
        assert "Logging error" not in err, err
    finally:
        root.handlers = before
        root.setLevel(level)
