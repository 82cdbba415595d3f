"""`scripts/study_day.py`: a planned study run against a real `cavewalk demo` server (its database,
timer, backups, log file, live WebSockets and UDP stream), shortened to one participant's two
sessions. The long run is a measurement (README, A study day), not a test."""

from __future__ import annotations

import json
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "study_day.py"


@pytest.mark.slow
def test_one_participants_two_sessions_are_stored_whole_and_backed_up(tmp_path: Path) -> None:
    folder = tmp_path / "day"
    report_path = tmp_path / "day.json"
    done = subprocess.run(
        [sys.executable, str(SCRIPT), "--participants", "1", "--run-s", "4", "--every", "1",
         "--warmup", "0", "--folder", str(folder), "--json", str(report_path),
         # a shared test machine: the stream may pause longer than a quiet lab PC's; the first
         # seconds' memory is the warm-up, not a leak (the long run measures that)
         "--max-quiet-s", "5", "--max-growth-mb", "300"],
        capture_output=True, text=True, check=False, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    report = json.loads(report_path.read_text())
    assert all(report["checks"].values()), report["checks"]
    assert report["sessions"] == 2
    # the first session asks the MSSQ once, then SSQ before, SSQ after, IPQ, NASA-TLX; the second no MSSQ
    assert report["sheets_sent"] == 9
    con = sqlite3.connect(f"file:{folder / 'study.db'}?mode=ro", uri=True)
    try:
        rows = con.execute(
            "SELECT s.stopped_by, q.instrument, q.phase, q.entered_by FROM questionnaire_responses q "
            "JOIN study_sessions s ON s.id = q.session_id ORDER BY q.id"
        ).fetchall()
    finally:
        con.close()
    assert [(r[1], r[2]) for r in rows] == [
        ("mssq", "pre"), ("ssq", "pre"), ("ssq", "post"), ("ipq", "post"), ("nasa_tlx", "post"),
        ("ssq", "pre"), ("ssq", "post"), ("ipq", "post"), ("nasa_tlx", "post"),
    ]  # fmt: skip
    assert {r[0] for r in rows} == {"timer"} and {r[3] for r in rows} == {"participant"}
    assert report["udp"]["by_type"].get("locomotion", 0) > 0, "the workstation heard commands"
    assert report["dashboard"]["live_messages"] > 0 and report["dashboard"]["reloads"] > 0
    assert report["backup"]["newest"].endswith("-stop.db"), "the server's own backup at its stop"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--participants", "0"], "error: out of range: --participants"),
        (["--run-s", "1"], "error: out of range: --run-s"),
        (["--every", "0", "--max-quiet-s", "-1"], "error: out of range: --every, --max-quiet-s"),
    ],
)
def test_bad_arguments_are_one_error_line(tmp_path: Path, args: list[str], message: str) -> None:
    done = subprocess.run(
        [sys.executable, str(SCRIPT), "--folder", str(tmp_path), *args], capture_output=True, text=True,
        check=False,
    )  # fmt: skip
    assert done.returncode == 2 and done.stderr.startswith(message), done.stderr
    assert list(tmp_path.iterdir()) == [], "nothing started, nothing written"


def test_a_database_already_there_is_refused(tmp_path: Path) -> None:
    (tmp_path / "study.db").write_bytes(b"a study's data")
    done = subprocess.run(
        [sys.executable, str(SCRIPT), "--folder", str(tmp_path)], capture_output=True, text=True, check=False
    )
    assert done.returncode == 2 and "exists: the day starts on a fresh database" in done.stderr
    assert (tmp_path / "study.db").read_bytes() == b"a study's data"


def test_a_folder_that_is_a_file_is_one_error_line(tmp_path: Path) -> None:
    taken = tmp_path / "taken"
    taken.write_text("a file where the day's folder would go")
    done = subprocess.run(
        [sys.executable, str(SCRIPT), "--folder", str(taken)], capture_output=True, text=True, check=False
    )
    assert done.returncode == 2 and done.stderr.startswith(f"error: --folder {taken}: "), done.stderr
    assert len(done.stderr.strip().splitlines()) == 1, "one line, no traceback"
