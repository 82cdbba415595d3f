"""`cavewalk serve` / `demo`: bad options end with one clear message (exit 2), never a traceback."""

from __future__ import annotations

import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

from app.cli import cli
from pipeline.errors import CavewalkError

ROOT = Path(__file__).resolve().parents[2]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture()
def busy_port() -> Iterator[int]:
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen()
    yield int(s.getsockname()[1])
    s.close()


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--emit", "nohostport"], "--emit"),
        (["--emit", "ws1:99999"], "port must be 1-65535"),
        (["--port", "busy"], "is in use"),
        (["--viser-port", "busy"], "is in use"),
        (["--db", "FOLDER"], "is a folder"),
        (["--config", "missing.toml"], "config file not found"),
        (["--db", "NOTADB"], "cannot be used: file is not a database"),
    ],
)
def test_bad_options_raise_a_cavewalk_error(
    args: list[str], match: str, busy_port: int, tmp_path: Path
) -> None:
    args = [str(busy_port) if a == "busy" else str(tmp_path) if a == "FOLDER" else a for a in args]
    args = [str(tmp_path / a) if a.endswith(".toml") else a for a in args]
    if "NOTADB" in args:
        notes = tmp_path / "notes.txt"
        notes.write_text("these are my notes, not a database\n" * 100)
        args[args.index("NOTADB")] = str(notes)
    if "--db" not in args:
        args += ["--db", str(tmp_path / "x.db")]
    for opt in ("--port", "--viser-port"):  # not 8000/8080, which another server here may hold
        if opt not in args:
            args += [opt, str(free_port())]
    result = CliRunner().invoke(cli, ["demo", *args])
    assert isinstance(result.exception, CavewalkError), result.output
    assert match in str(result.exception)
    assert not (tmp_path / "x.db").exists(), "a refused start creates no database"
    if (tmp_path / "notes.txt").exists():
        assert (tmp_path / "notes.txt").read_text().startswith("these are my notes"), "left unchanged"


@pytest.mark.slow
def test_main_prints_one_line_and_exits_2(busy_port: int, tmp_path: Path) -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "app.cli", "serve", "--port", str(busy_port), "--db", str(tmp_path / "a.db")],
        cwd=ROOT, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert proc.returncode == 2
    assert (
        proc.stderr.strip().splitlines()[-1]
        == f"error: port {busy_port} on 127.0.0.1 is in use (choose another with --port)"
    )
    assert "Traceback" not in proc.stderr
