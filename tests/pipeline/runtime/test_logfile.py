"""The server's log file: the rotating process and a worker process append to one file, and a
worker's records go to the new file once the file was rotated under it."""

from __future__ import annotations

import logging
import multiprocessing as mp
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from pipeline.runtime.logfile import LogFileConfig, log_to_file


@pytest.fixture()
def root_handlers() -> Iterator[None]:
    """The root logger holds only the handlers the test adds (a handler an earlier test in this
    process left, on a stream since closed, would print its own logging errors); afterwards they
    are closed and the earlier ones are back."""
    root = logging.getLogger()
    before, level = list(root.handlers), root.level
    root.handlers = []
    yield
    for h in root.handlers:
        h.close()
    root.handlers = before
    root.setLevel(level)


def _worker(config: LogFileConfig, wrote: Any, rotated: Any) -> None:
    """A worker process: a batch of records, then (once the app's process rotated the file) another."""
    logging.getLogger().setLevel(logging.INFO)
    log_to_file(config, rotate=False)
    for batch in (0, 1):
        for i in range(BATCH):
            logging.getLogger("cw.worker").info("worker record %d-%02d %s", batch, i, "w" * 200)
        wrote.set()
        if batch == 0 and not rotated.wait(60):
            raise SystemExit(3)


BATCH = 30


def _lines(path: Path, prefix: str) -> list[str]:
    return [line for line in path.read_text(encoding="utf-8").splitlines() if prefix in line]


def test_a_worker_writes_to_the_new_file_after_the_app_s_process_rotated_it(
    tmp_path: Path, root_handlers: None
) -> None:
    """The app's process rotates (20 KB files) between two batches of a worker process's records:
    the first batch is in the old file, the second in the new one (a worker that kept the renamed
    file open would write it there), each record whole and once."""
    config = LogFileConfig(path=tmp_path / "logs" / "cavewalk.log", max_mb=0.02, keep=4)
    logging.getLogger().setLevel(logging.INFO)
    assert log_to_file(config, rotate=True) == config.path
    assert log_to_file(config, rotate=True) == config.path, "a second call adds no second handler"
    assert len([h for h in logging.getLogger().handlers if getattr(h, "_cavewalk_file", None)]) == 1
    ctx = mp.get_context("spawn")
    wrote, rotated = ctx.Event(), ctx.Event()
    worker = ctx.Process(target=_worker, args=(config, wrote, rotated))
    worker.start()
    assert wrote.wait(60), "the worker's first batch"
    wrote.clear()
    app = logging.getLogger("cw.app")
    for i in range(90):  # ~270 bytes each: the file passes 20 KB once, and is rotated
        app.info("app record %03d %s", i, "a" * 200)
    rotated.set()
    assert wrote.wait(60), "the worker's second batch"
    worker.join(timeout=60)
    assert worker.exitcode == 0
    logs = tmp_path / "logs"
    assert sorted(p.name for p in logs.iterdir()) == ["cavewalk.log", "cavewalk.log.1"]
    assert logs.joinpath("cavewalk.log.1").stat().st_size < 20_000 + 600  # one record past at most
    old = _lines(logs / "cavewalk.log.1", "worker record")
    new = _lines(logs / "cavewalk.log", "worker record")
    assert [line.split("worker record ")[1][:4] for line in old] == [f"0-{i:02d}" for i in range(BATCH)]
    assert [line.split("worker record ")[1][:4] for line in new] == [f"1-{i:02d}" for i in range(BATCH)]
    assert all(line.endswith("w" * 200) and "cw.worker" in line for line in old + new)
    app_lines = _lines(logs / "cavewalk.log.1", "app record") + _lines(logs / "cavewalk.log", "app record")
    assert [int(line.split("app record ")[1][:3]) for line in app_lines] == list(range(90))


def test_a_second_file_replaces_the_first_and_nothing_is_written_without_a_path(
    tmp_path: Path, root_handlers: None
) -> None:
    assert log_to_file(LogFileConfig(), rotate=True) is None
    assert log_to_file(LogFileConfig(enabled=False, path=tmp_path / "x.log"), rotate=True) is None
    assert not (tmp_path / "x.log").exists()
    log_to_file(LogFileConfig(path=tmp_path / "a.log"), rotate=True)
    log_to_file(LogFileConfig(path=tmp_path / "b.log"), rotate=True)
    logging.getLogger("cw.test").warning("only in b")
    assert "only in b" in (tmp_path / "b.log").read_text()
    assert "only in b" not in (tmp_path / "a.log").read_text()


def test_a_log_file_that_cannot_be_opened_is_an_os_error(tmp_path: Path, root_handlers: None) -> None:
    (tmp_path / "plain").write_text("a file where the folder should be\n")
    with pytest.raises(OSError):
        log_to_file(LogFileConfig(path=tmp_path / "plain" / "cavewalk.log"), rotate=True)


@pytest.mark.parametrize(("kw", "match"), [({"max_mb": 0}, "max_mb"), ({"keep": 0}, "keep")])
def test_bad_log_settings_are_refused(kw: dict[str, float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        LogFileConfig(**kw)  # type: ignore[arg-type]


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (Linux)")
def test_a_log_file_that_cannot_be_written_is_one_line_on_stderr(
    root_handlers: None, capfd: pytest.CaptureFixture[str]
) -> None:
    """/dev/full answers every write with ENOSPC, as a full disk does: one line says so, not a
    traceback per record."""
    logging.getLogger().setLevel(logging.INFO)
    log_to_file(LogFileConfig(path=Path("/dev/full")), rotate=False)
    for i in range(3):
        logging.getLogger("cw.test").info("record %d", i)
    err = capfd.readouterr().err
    said = [line for line in err.splitlines() if line.startswith("cavewalk: cannot write the log file")]
    assert len(said) == 1 and "No space left on device" in said[0], err
    assert "Logging error" not in err and "Traceback" not in err, err
