"""`cavewalk record` through the real entry point: its own simulator pipeline, a running server
(``--url``), and bad invocations (one ``error:`` line, exit 2, nothing written)."""

from __future__ import annotations

import contextlib
import json
import os
import socket
import subprocess
import sys
import threading
import time
import zipfile
from collections.abc import Iterator
from pathlib import Path

import av
import httpx
import numpy as np
import pytest

from app.db.engine import make_engine, make_session_factory
from app.db.migrate import prepare_database
from app.db.take_repository import create_take, take_by_uid
from pipeline.demo_data import DemoData
from pipeline.takes.files import check_files
from tests.app.conftest import Served, make_settings
from tests.app.test_cli_errors import run_cli
from tests.disk import need_free_gb, take_space
from tests.waiting import free_port, wait_until

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--duration", "2", "--protocol", "no-such"], "neither a .toml file nor a shipped protocol"),
        (["--protocol", "four-actions", "--margin", "9"], "--margin must be"),
        (["--protocol", "four-actions", "--margin", "-0.1"], "--margin must be"),
        ([], "give --duration or --protocol"),
        (["--duration", "2", "--videos"], "the simulator has no camera images"),
        (["--duration", "0"], "--duration must be"),
        (["--duration", "2", "--source", "tv"], "--source must be"),
        (["--duration", "2", "--source", "videos"], "needs --video"),
        (["--duration", "2", "--protocol", "PROTO"], "unknown label 'hop'"),
        (["--duration", "2", "--url", "http://127.0.0.1:9"], "cannot reach the server"),
        (["--duration", "2", "--url", "http://127.0.0.1:9", "--reconnect-s", "0"], "--reconnect-s must be"),
        (
            ["--duration", "2", "--url", "http://127.0.0.1:9", "--db", "x.db"],
            "--db is for a take recorded here",
        ),
    ],
)
def test_bad_record_invocations_end_with_one_error_and_write_nothing(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    args: list[str],
    match: str,
) -> None:
    proto = tmp_path / "bad.toml"
    proto.write_text('name = "bad"\nsteps = ["still 2 s", "hop 2 s"]\n')
    args = [str(proto) if a == "PROTO" else a for a in args]
    out = tmp_path / "take"
    code = run_cli(["record", "--out", str(out), *args], monkeypatch)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err[-1].startswith("error: ") and match in err[-1], err
    assert not out.exists()


def test_record_refuses_an_existing_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "take").mkdir()
    (tmp_path / "take" / "keep.txt").write_text("mine")
    code = run_cli(["record", "--out", str(tmp_path / "take"), "--duration", "1"], monkeypatch)
    assert code == 2 and "already exists" in capsys.readouterr().err
    assert [p.name for p in (tmp_path / "take").iterdir()] == ["keep.txt"]


def test_record_refuses_a_name_the_index_already_has(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "index.db"
    prepare_database(db)
    engine = make_engine(db)
    with make_session_factory(engine)() as session:
        create_take(session, uid="take", folder=str(tmp_path / "elsewhere"), status="complete", files={})
    engine.dispose()
    before = db.read_bytes()
    code = run_cli(
        ["record", "--out", str(tmp_path / "take"), "--duration", "1", "--db", str(db)], monkeypatch
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and "already has a take 'take'; choose another --out name" in err[-1], err
    assert not (tmp_path / "take").exists() and db.read_bytes() == before


def test_record_backs_up_an_older_index_before_it_migrates_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """An index an older cavewalk left (revision 0004): the ``before-upgrade`` copy is made before the
    migration, whatever the command then decides (here: the name is taken)."""
    from app.db.backup import inspect_database, list_backups
    from app.db.migrate import head_revision, upgrade

    db = tmp_path / "index.db"
    engine = make_engine(db)
    upgrade(engine, "0004_takes")
    with make_session_factory(engine)() as session:
        create_take(session, uid="take", folder=str(tmp_path / "elsewhere"), status="complete", files={})
    engine.dispose()
    code = run_cli(
        ["record", "--out", str(tmp_path / "take"), "--duration", "1", "--db", str(db)], monkeypatch
    )
    assert code == 2 and "already has a take 'take'" in capsys.readouterr().err
    (before,) = list_backups(tmp_path / "backups", db)
    assert before.reason == "before-upgrade" and inspect_database(before.path)[0] == "0004_takes"
    assert inspect_database(db)[0] == head_revision()


def test_record_refuses_to_start_on_a_full_disk_and_writes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The real free space is below ``storage.min_free_gb`` (set above it): one error, no folder,
    no index database."""
    monkeypatch.setenv("CAVEWALK_STORAGE__WARN_FREE_GB", "1000000")
    monkeypatch.setenv("CAVEWALK_STORAGE__MIN_FREE_GB", "1000000")
    db = tmp_path / "index.db"
    args = ["record", "--out", str(tmp_path / "take"), "--duration", "1", "--db", str(db)]
    code = run_cli(args, monkeypatch)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err[-1].startswith("error: the take refused: the disk is nearly full"), err
    assert "storage.min_free_gb" in err[-1]
    assert not (tmp_path / "take").exists() and not db.exists()


@pytest.mark.slow
def test_record_stops_a_take_when_the_disk_fills_up_and_keeps_it(tmp_path: Path, disk_alone: None) -> None:
    """A real file takes 3 GB away while ``cavewalk record`` records 120 s: the take stops within a
    few checks, is kept and indexed, and the command says why (exit 1)."""
    free = need_free_gb(tmp_path, 8)
    out, db, ballast = tmp_path / "take", tmp_path / "index.db", tmp_path / "ballast.bin"
    env = {
        **os.environ,
        "CAVEWALK_STORAGE__WARN_FREE_GB": f"{free - 1.5:.3f}",
        "CAVEWALK_STORAGE__MIN_FREE_GB": f"{free - 1.5:.3f}",
        "CAVEWALK_STORAGE__CHECK_S": "0.2",
    }
    cmd = [sys.executable, "-m", "app.cli", "record", "--out", str(out), "--duration", "120", "--db", str(db)]
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_until(lambda: (out / "take.json").exists() or proc.poll() is not None, "the take to begin", 120)
        assert proc.poll() is None, proc.communicate()[1][-2000:]
        time.sleep(1.0)
        take_space(ballast, 3 * 10**9)
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
        ballast.unlink(missing_ok=True)
    err = stderr.strip().splitlines()
    assert proc.returncode == 1, stderr[-2000:]
    assert err[-1].startswith("error: the take stopped early: the disk is nearly full"), err[-3:]
    summary = json.loads(stdout.strip().splitlines()[-1])
    assert summary["status"] == "complete" and 0.5 < summary["duration_s"] < 30, summary
    assert check_files(out) == []
    engine = make_engine(db)
    with make_session_factory(engine)() as session:
        row = take_by_uid(session, "take")
        assert row is not None and row.frames == summary["frames"]
    engine.dispose()


@pytest.mark.slow
def test_record_runs_its_own_simulator_pipeline_indexes_and_exports_the_take(tmp_path: Path) -> None:
    out, db = tmp_path / "take", tmp_path / "index.db"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "app.cli",
            "record",
            "--out",
            str(out),
            "--protocol",
            "four-actions",
            "--duration",
            "3",
            "--participant",
            "S1",
            "--margin",
            "0.3",
            "--db",
            str(db),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    assert summary["status"] == "complete" and summary["frames"] > 10, summary
    manifest = json.loads((out / "take.json").read_text())
    assert manifest["participant_code"] == "S1" and manifest["protocol"]["name"] == "four actions"
    assert check_files(out) == []
    with np.load(out / "skeletons.npz") as npz:
        assert npz["joints"].shape == (summary["frames"], 17, 3)
        labels = npz["labels"].tolist()
        # the first 3 s of four-actions are still; ignore where the participant was not the navigator
        assert set(labels) <= {"still", "ignore"} and labels.count("still") >= 0.8 * len(labels), labels
        joints = npz["joints"]
    # indexed like a server's take, its row pointing at the folder
    engine = make_engine(db)
    with make_session_factory(engine)() as session:
        row = take_by_uid(session, "take")
        assert row is not None and row.folder == str(out.resolve()) and row.status == "complete"
        assert row.participant_code == "S1" and row.frames == summary["frames"]
        assert row.files == manifest["files"] and manifest["take_id"] == row.id
    engine.dispose()
    # exported: the TRC holds the participant's joints, Y-up (the simulated person stands: Y is up)
    trc = tmp_path / "take.trc"
    proc = subprocess.run(
        [sys.executable, "-m", "app.cli", "export", str(out), "--out", str(trc)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = [line.split("\t") for line in trc.read_text().splitlines()[5:]]
    ankle_y = [float(r[2 + 3 * 15 + 1]) for r in rows if r[2 + 3 * 15 + 1]]
    nose_y = [float(r[2 + 1]) for r in rows if r[2 + 1]]
    assert ankle_y and nose_y and np.median(nose_y) - np.median(ankle_y) > 1.0, "Y is up, in metres"
    assert abs(np.nanmedian(joints[:, 0, 2]) - np.median(nose_y)) < 0.05, "TRC Y = the CAVE's Z"


@pytest.fixture()
def served(tmp_path: Path) -> Iterator[Served]:
    with Served(make_settings(tmp_path)) as s:
        s.wait_status(lambda st: st["state"] == "running" and st["navigator"] is not None, 60)
        yield s


@pytest.mark.slow
def test_record_on_a_running_server_fetches_the_take(served: Served, tmp_path: Path) -> None:
    out = tmp_path / "fetched"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "app.cli",
            "record",
            "--out",
            str(out),
            "--url",
            served.base,
            "--protocol",
            str(ROOT / "protocols" / "teach.toml"),
            "--duration",
            "2.5",
            "--participant",
            "R1",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "Stand still" in proc.stderr, "the prompt is shown while it records"
    manifest = json.loads((out / "take.json").read_text())
    assert manifest["status"] == "complete" and manifest["participant_code"] == "R1"
    assert check_files(out) == [], "every file came with a matching sha256"
    assert manifest["take_id"] == 1 and (out / "labels.csv").read_text().startswith("t_start,t_end,label")


class Relay:
    """The lab's network between ``cavewalk record --url`` and the server: a TCP relay on a port of
    its own that can be cut (its listener closed, every open connection dropped) and restored."""

    def __init__(self, target_port: int) -> None:
        self.port, self.target = free_port(), target_port
        self._lock = threading.Lock()
        self._socks: list[socket.socket] = []
        self._listener: socket.socket | None = None
        self.restore()

    def restore(self) -> None:
        listener = socket.socket()
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        listener.bind(("127.0.0.1", self.port))
        listener.listen(16)
        self._listener = listener
        threading.Thread(target=self._accept, args=(listener,), daemon=True).start()

    def _accept(self, listener: socket.socket) -> None:
        while True:
            try:
                client, _ = listener.accept()
                upstream = socket.create_connection(("127.0.0.1", self.target))
            except OSError:
                return  # cut
            with self._lock:
                self._socks += [client, upstream]
            for a, b in ((client, upstream), (upstream, client)):
                threading.Thread(target=self._pump, args=(a, b), daemon=True).start()

    @staticmethod
    def _pump(src: socket.socket, dst: socket.socket) -> None:
        try:
            while data := src.recv(65536):
                dst.sendall(data)
        except OSError:
            pass
        finally:
            for sock in (src, dst):
                with contextlib.suppress(OSError):
                    sock.shutdown(socket.SHUT_RDWR)

    def cut(self) -> None:
        if self._listener is not None:
            with contextlib.suppress(OSError):
                self._listener.shutdown(socket.SHUT_RDWR)  # wakes its accept(): close alone does not
            self._listener.close()
            self._listener = None
        with self._lock:
            socks, self._socks = self._socks, []
        for sock in socks:
            with contextlib.suppress(OSError):
                sock.shutdown(socket.SHUT_RDWR)
            sock.close()


class Recording:
    """``cavewalk record --url`` through ``relay``, its stderr lines gathered as they come."""

    def __init__(self, relay: Relay, out: Path, *extra: str) -> None:
        cmd = [sys.executable, "-m", "app.cli", "record", "--out", str(out), "--url",
               f"http://127.0.0.1:{relay.port}", "--duration", "6", *extra]
        self.proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        wait_until(lambda: any("recording take" in ln for ln in self.lines) or self.proc.poll() is not None,
                   "the take")
        assert self.proc.poll() is None, "".join(self.lines)[-2000:]

    def _read(self) -> None:
        assert self.proc.stderr is not None
        self.lines.extend(iter(self.proc.stderr.readline, ""))

    def finish(self) -> tuple[int, str, str]:
        """Exit status, stdout, stderr (all of it)."""
        code = self.proc.wait(timeout=120)
        self._reader.join(timeout=10)
        assert self.proc.stdout is not None
        return code, self.proc.stdout.read(), "".join(self.lines)


@pytest.fixture()
def relay(served: Served) -> Iterator[Relay]:
    """A relay to the running server, cut at the end."""
    r = Relay(int(served.base.rsplit(":", 1)[1]))
    yield r
    r.cut()


@pytest.mark.slow
def test_record_on_a_server_rides_out_a_lost_connection_and_fetches_the_take(
    relay: Relay, tmp_path: Path
) -> None:
    out = tmp_path / "fetched"
    rec = Recording(relay, out)
    time.sleep(1.0)
    relay.cut()  # 2 s without a network while the take records
    time.sleep(2.0)
    relay.restore()
    code, stdout, err = rec.finish()
    assert code == 0, err[-2000:]
    assert "lost the server" in err and "the server answers again" in err, err
    assert json.loads(stdout.strip().splitlines()[-1])["status"] == "complete"
    assert check_files(out) == [], "every file came with a matching sha256"


@pytest.mark.slow
def test_record_on_a_server_lost_for_good_ends_with_one_error_and_the_take_goes_on_there(
    served: Served, relay: Relay, tmp_path: Path
) -> None:
    out = tmp_path / "fetched"
    rec = Recording(relay, out, "--reconnect-s", "2")
    relay.cut()
    code, _, text = rec.finish()
    err = text.rstrip().splitlines()
    assert code == 2, err
    assert err[-1].startswith("error: the server at http://127.0.0.1:"), err
    assert "take 1 goes on there and is kept" in err[-1], err
    assert "Traceback" not in text
    assert not out.exists(), "nothing half-fetched"
    take = wait_until(
        lambda: (t := httpx.get(f"{served.base}/api/v1/takes/1").json())["status"] != "recording" and t,
        "the take to end on the server",
    )
    assert take["status"] == "complete", take


@pytest.mark.slow
def test_record_from_the_demo_videos_writes_a_video_per_camera_on_the_takes_clock(
    tmp_path: Path, demo_data: DemoData
) -> None:
    out, db = tmp_path / "vtake", tmp_path / "index.db"
    cams = ("cam01", "cam02")
    args = [f"--video={c}={demo_data.videos[c]}" for c in cams]
    proc = subprocess.run(
        [sys.executable, "-m", "app.cli", "record", "--out", str(out), "--source", "videos", *args,
         "--calibration", str(demo_data.calibration), "--duration", "3", "--videos", "--db", str(db)],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
        env={**os.environ, "CAVEWALK_RUNTIME__VIDEO_PACE_FPS": "10"},  # a third of the decoding of 30
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    manifest = json.loads((out / "take.json").read_text())
    assert check_files(out) == [], "every video is listed with its sha256"
    written = 0
    for cam in cams:
        stats = manifest["videos"][cam]
        assert stats["state"] == "closed" and stats["error"] is None, stats
        name = f"videos/{cam}.mp4"
        print(f"{cam}: {stats['written']} frames written, {stats['dropped']} dropped in 3 s")
        if not stats["written"]:  # a capture worker (niced) that got no CPU in the take: no file
            assert name not in manifest["files"] and not (out / name).exists(), stats
            continue
        written += stats["written"]
        assert name in manifest["files"], sorted(manifest["files"])
        with av.open(str(out / name)) as c:
            frames = list(c.decode(video=0))
        assert len(frames) == stats["written"], (len(frames), stats)
        times = [float(f.time) for f in frames]
        assert all(0 <= t < 3.0 for t in times) and times == sorted(times), times
        assert (frames[0].width, frames[0].height) == (1080, 1920), "as captured (no long_side)"
    assert written >= 1, manifest["videos"]
    # the zip holds them byte for byte
    zipped = tmp_path / "vtake.zip"
    proc = subprocess.run([sys.executable, "-m", "app.cli", "export", str(out), "--out", str(zipped)],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    with zipfile.ZipFile(zipped) as zf:
        for name in (n for n in manifest["files"] if n.startswith("videos/")):
            assert zf.read(f"vtake/{name}") == (out / name).read_bytes(), name
