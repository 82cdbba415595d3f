"""`cavewalk data mocap` through the command line (reuses the user cache that fetch_mocap fills)."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from app.cli import cli

pytestmark = pytest.mark.slow


def test_data_mocap_prints_what_it_wrote_and_is_idempotent() -> None:
    runner = CliRunner()
    first = runner.invoke(cli, ["data", "mocap"])
    assert first.exit_code == 0, first.output
    second = runner.invoke(cli, ["data", "mocap"])
    assert second.exit_code == 0, second.output
    assert "mocap clips ready: 20" in second.output
    assert "20 clips (index.json beside them)" in second.output
