"""``cavewalk record``: a take, from a running server (``--url``) or from a pipeline it runs itself."""

from __future__ import annotations

import hashlib
import json
import shutil
import signal
import threading
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from app.core.config import Settings, get_settings
from pipeline.errors import InputError, SourceError
from pipeline.takes.files import MANIFEST, write_json
from pipeline.takes.protocol import (
    Protocol,
    check_margin,
    label_spans,
    load_protocol,
    parse_protocol_text,
    shipped_protocols,
)
from pipeline.takes.video import VideoSession

if TYPE_CHECKING:
    from app.services.storage import StorageWatch

app = typer.Typer()


def _protocol_arg(value: str | None) -> tuple[Protocol | None, str | None, str | None]:
    """(protocol, shipped name, TOML text) of ``--protocol`` (a file or a shipped protocol's name)."""
    if value is None:
        return None, None, None
    path = Path(value)
    if path.suffix == ".toml" or path.exists():
        if not path.is_file():
            raise InputError(f"--protocol: file not found: {path}")
        text = path.read_text(encoding="utf-8")
        return parse_protocol_text(text, str(path)), None, text
    shipped = shipped_protocols()
    if value not in shipped:
        raise InputError(
            f"--protocol: {value!r} is neither a .toml file nor a shipped protocol ({', '.join(shipped)})"
        )
    return load_protocol(shipped[value]), value, None


def _stop_on_signals(stop: threading.Event) -> None:
    def handler(_signum: int, _frame: Any) -> None:
        stop.set()

    signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGTERM, handler)


def _check_out(out: Path) -> None:
    if out.exists():
        raise InputError(f"--out {out} already exists; a take goes into a new folder")
    if out.parent.exists() and not out.parent.is_dir():
        raise InputError(f"--out {out}: {out.parent} is not a directory")


# ------------------------------------------------------------------------------ from a server
class _Server:
    """Requests to a server whose take records: a request that cannot reach it (the lab's network,
    a restart) is tried again for ``reconnect_s``; then one error, which says the take goes on there."""

    def __init__(self, client: Any, url: str, take: int, reconnect_s: float) -> None:
        self.client, self.url, self.take, self.reconnect_s = client, url, take, reconnect_s

    def call(self, method: str, path: str) -> Any:
        import httpx

        lost_at = None
        while True:
            try:
                r = self.client.request(method, path)
            except httpx.TransportError as exc:
                now = time.monotonic()
                if lost_at is None:
                    lost_at = now
                    typer.echo(f"  lost the server ({exc}); trying again for {self.reconnect_s:g} s",
                               err=True)
                if now - lost_at > self.reconnect_s:
                    raise SourceError(
                        f"the server at {self.url} could not be reached for {self.reconnect_s:g} s ({exc}); "
                        f"take {self.take} goes on there and is kept: fetch it from the dashboard's takes"
                    ) from None
                time.sleep(0.5)
                continue
            if lost_at is not None:
                typer.echo("  the server answers again", err=True)
            return r


def _record_remote(
    url: str, token: str | None, body: dict[str, Any], out: Path, stop: threading.Event, reconnect_s: float
) -> dict:
    import httpx

    headers = {"Authorization": f"Bearer {token}"} if token else {}
    api = url.rstrip("/") + "/api/v1"
    with httpx.Client(headers=headers, timeout=30) as client:
        try:
            r = client.post(f"{api}/takes", json=body)
        except httpx.HTTPError as exc:
            raise SourceError(f"cannot reach the server at {url}: {exc}") from None
        if r.status_code != 201:
            raise InputError(f"the server refused the take ({r.status_code}): {_detail(r)}")
        take = r.json()
        server = _Server(client, url, take["id"], reconnect_s)
        typer.echo(f"recording take {take['id']} ({take['uid']}) on {url}", err=True)
        last_text = None
        while True:
            row = server.call("GET", f"{api}/takes/{take['id']}").json()
            if row["status"] != "recording":
                break
            if stop.is_set():
                server.call("POST", f"{api}/takes/{take['id']}/stop")
                continue
            cur = server.call("GET", f"{api}/takes/current").json()
            prompt = cur.get("prompt") if cur.get("take_id") == take["id"] else None
            if prompt and prompt["text"] != last_text:
                last_text = prompt["text"]
                typer.echo(f"  [{prompt['index'] + 1}/{prompt['steps']}] {prompt['text']}", err=True)
            stop.wait(0.25)
        out.mkdir(parents=True)
        try:
            for name in [*row["files"], MANIFEST]:
                got = server.call("GET", f"{api}/takes/{take['id']}/files/{name}")
                if got.status_code != 200:
                    raise SourceError(f"could not fetch {name} of take {take['id']}: {_detail(got)}")
                info = row["files"].get(name)
                if info and hashlib.sha256(got.content).hexdigest() != info["sha256"]:
                    raise SourceError(f"{name} of take {take['id']} does not match its sha256")
                (out / name).parent.mkdir(parents=True, exist_ok=True)
                (out / name).write_bytes(got.content)
        except BaseException:
            shutil.rmtree(out, ignore_errors=True)  # no half-fetched folder: the server keeps the take
            raise
        return json.loads((out / MANIFEST).read_text())


def _detail(r: Any) -> str:
    try:
        return str(r.json().get("detail"))
    except ValueError:
        return r.text[:200]


# ------------------------------------------------------------------------------- on its own
def _record_local(
    settings: Settings,
    source: str,
    video_files: dict[str, Path],
    calibration: Path | None,
    protocol: Protocol | None,
    duration: float | None,
    margin: float,
    participant: str | None,
    out: Path,
    stop: threading.Event,
    disk: StorageWatch,
    videos: bool = False,
) -> tuple[dict, str | None]:
    """The take's manifest, and why it stopped early when the disk became full (None: it did not)."""
    # the pipeline (cv2, scipy) and the database (SQLAlchemy) are imported where they are used: start-up time
    from app.services.pipeline_factory import build_pipeline, simulator_factory
    from app.services.recorder import model_identity, settings_snapshot
    from pipeline.calibration.io import calibration_to_dict, load_calibration
    from pipeline.takes.recorder import TakeRecorder

    cameras = load_calibration(calibration) if calibration else None
    sim = simulator_factory(settings)
    pipeline = build_pipeline(settings, cameras, sim)
    cal = calibration_to_dict(cameras) if cameras else calibration_to_dict(sim.cameras)
    manifest = {
        "id": out.name,
        "take_id": None,
        "participant_code": participant,
        "session_id": None,
        "source": source,
        "margin_s": margin,
        "lead_s": settings.takes.lead_s,
        "notes": "",
        "calibration_id": str(calibration) if calibration else None,
        "model": model_identity(settings.recognition.model_path),
        "settings": settings_snapshot(settings),
    }
    spans = label_spans(protocol, margin, settings.takes.lead_s) if protocol else []
    recorder: TakeRecorder | None = None
    try:
        pipeline.start(source, video_files or None)  # type: ignore[arg-type]
        deadline = time.monotonic() + 120
        while pipeline.status().frame_index < 0:  # the first fused frame: the pipeline is up
            if stop.wait(0.2) or time.monotonic() > deadline:
                raise SourceError(
                    f"the pipeline gave no frame ({pipeline.status().last_error or 'starting'})"
                )
        controls = pipeline.video_controls() if videos else {}
        if videos and not controls:
            raise InputError(
                f"--videos: the {source} source has no camera images; use cameras or --video files"
            )
        recorder = TakeRecorder(
            out,
            manifest,
            settings.takes,
            protocol=protocol,
            spans=spans,
            duration_s=duration,
            calibration=cal,
            videos=VideoSession(controls, out / "videos", settings.takes) if controls else None,
        )
        full: list[str] = []
        disk.on_full(full.append)  # the watch's thread: checked every storage.check_s
        disk.start()
        recorder.start()
        pipeline.add_sink(recorder)
        typer.echo(f"recording {out} from {source}", err=True)
        last = None
        while not recorder.wait(0.25):
            if stop.is_set() or full:
                break
            p = recorder.prompt()
            if p is not None and p[0] != last:
                last = p[0]
                typer.echo(f"  [{p[0] + 1}/{len(protocol.steps) if protocol else 0}] {p[1].text}", err=True)
        return recorder.stop(), full[0] if full else None
    finally:
        disk.close()
        if recorder is not None:
            pipeline.remove_sink(recorder)
        pipeline.close()


# ------------------------------------------------------------------------------- the index
def _check_index(db: Path, uid: str) -> None:
    """Before recording: the database can be used and has no take named ``uid`` yet."""
    from app.db.engine import make_engine, make_session_factory
    from app.db.migrate import prepare_database
    from app.db.take_repository import take_by_uid

    prepare_database(db)
    engine = make_engine(db)
    try:
        with make_session_factory(engine)() as session:
            if take_by_uid(session, uid) is not None:
                raise InputError(f"the index {db} already has a take {uid!r}; choose another --out name")
    finally:
        engine.dispose()


def _index_take(db: Path, out: Path, manifest: dict[str, Any]) -> int:
    """A take recorded here goes into the takes index like a server's (its row points to ``out``)."""
    from app.db.engine import make_engine, make_session_factory
    from app.db.take_repository import create_take, finish_take_row

    engine = make_engine(db)
    try:
        with make_session_factory(engine)() as session:
            start = manifest.get("start_unix")
            row = create_take(
                session,
                uid=manifest["id"],
                folder=str(out.resolve()),
                status="recording",
                participant_code=manifest.get("participant_code"),
                session_id=None,
                protocol=(manifest.get("protocol") or {}).get("name"),
                source=manifest.get("source"),
                started_at=datetime.fromtimestamp(float(start), UTC) if start else datetime.now(UTC),
                margin_s=manifest.get("margin_s") if manifest.get("protocol") else None,
                calibration_run_id=None,
                files={},
                notes="recorded by cavewalk record",
            )
            status = "complete" if manifest.get("complete") else "incomplete"
            finish_take_row(session, row.id, manifest, status)
            return row.id
    finally:
        engine.dispose()


@app.command("record")
def record_cmd(
    out: Annotated[Path, typer.Option("--out", help="The take's folder (must not exist yet).")],
    duration: Annotated[
        float | None, typer.Option("--duration", help="Seconds (default: the protocol's).")
    ] = None,
    protocol: Annotated[
        str | None,
        typer.Option(
            "--protocol",
            help="A protocol TOML file, or a shipped protocol's name (four-actions, no-intent, teach).",
        ),
    ] = None,
    margin: Annotated[
        float | None, typer.Option("--margin", help="Reaction margin after each label change, s.")
    ] = None,
    participant: Annotated[str | None, typer.Option("--participant", help="The participant's code.")] = None,
    url: Annotated[
        str | None, typer.Option("--url", help="Record on this running server (http://host:port).")
    ] = None,
    token: Annotated[str | None, typer.Option("--token", help="The server's operator token.")] = None,
    source: Annotated[
        str, typer.Option("--source", help="Without --url: simulator, cameras or videos.")
    ] = "simulator",
    video: Annotated[list[str] | None, typer.Option("--video", help="NAME=PATH (the videos source).")] = None,
    calibration: Annotated[
        Path | None, typer.Option("--calibration", help="Cameras of the videos/cameras.")
    ] = None,
    with_videos: Annotated[
        bool, typer.Option("--videos", help="Also one MP4 per camera (cameras or video files).")
    ] = False,
    reconnect_s: Annotated[
        float,
        typer.Option(
            "--reconnect-s",
            help="With --url: how long a server that cannot be reached is tried again, s "
            "(the take goes on there).",
        ),
    ] = 30.0,
    db: Annotated[
        Path | None,
        typer.Option(
            "--db",
            help="Without --url: the SQLite database that indexes the take (default: "
            "the settings' paths.db).",
        ),
    ] = None,
) -> None:
    """Record a take: 3D skeletons with user ids, 2D detections, the recogniser's outputs, the
    navigator, timestamps, calibration and settings, labelled by the protocol."""
    settings = get_settings()
    _check_out(out)
    proto, shipped_name, toml_text = _protocol_arg(protocol)
    if duration is None and proto is None:
        raise InputError("give --duration or --protocol")
    if duration is not None and not 0 < duration <= settings.takes.max_duration_s:
        raise InputError(f"--duration must be in (0, {settings.takes.max_duration_s:g}] s, got {duration}")
    margin_s = check_margin(settings.takes.margin_s if margin is None else margin, "--margin")
    stop = threading.Event()
    _stop_on_signals(stop)
    disk_full = None  # why a take recorded here stopped early: the disk became full
    if url is not None:
        if db is not None:
            raise InputError("--db is for a take recorded here; with --url the server indexes it")
        body = {
            "participant_code": participant,
            "protocol": shipped_name,
            "protocol_toml": toml_text,
            "duration_s": duration,
            "margin_s": margin_s,
            "videos": with_videos or None,
        }
        if not 0 < reconnect_s <= 3600:
            raise InputError(f"--reconnect-s must be in (0, 3600] s, got {reconnect_s}")
        manifest = _record_remote(
            url, token, {k: v for k, v in body.items() if v is not None}, out, stop, reconnect_s
        )
    else:
        if source not in ("simulator", "cameras", "videos"):
            raise InputError(f"--source must be simulator, cameras or videos, got {source!r}")
        videos = {}
        for item in video or []:
            name, sep, path = item.partition("=")
            if not sep or not name or not path:
                raise InputError(f"--video must be NAME=PATH, got {item!r}")
            videos[name] = Path(path)
        if source == "videos" and not videos:
            raise InputError("--source videos needs --video NAME=PATH for each camera")
        if videos and source != "videos":
            raise InputError("--video is only for --source videos")
        if calibration is not None and not calibration.is_file():
            raise InputError(f"--calibration: file not found: {calibration}")
        index_db = (db or settings.paths.db).expanduser()
        if with_videos and source == "simulator":
            raise InputError("--videos: the simulator has no camera images; use --source cameras or videos")
        from app.services.backup import backup_before_upgrade
        from app.services.storage import DiskFull, StorageWatch

        disk = StorageWatch({"take": out, "database": index_db}, settings.storage)
        if (state := disk.check())["level"] == "full":
            raise DiskFull(f"the take refused: {state['message']}")
        backup_before_upgrade(index_db, settings.backup)  # an older cavewalk's database: copied first
        _check_index(index_db, out.name)
        manifest, disk_full = _record_local(
            settings,
            source,
            videos,
            calibration,
            proto,
            duration,
            margin_s,
            participant,
            out,
            stop,
            disk,
            with_videos,
        )
        manifest["take_id"] = _index_take(index_db, out, manifest)
        write_json(out / MANIFEST, manifest)
        typer.echo(f"indexed as take {manifest['take_id']} in {index_db}", err=True)
    typer.echo(json.dumps({k: manifest.get(k) for k in ("id", "status", "frames", "duration_s")}))
    typer.echo(
        f"take written to {out} ({manifest.get('status')}, {manifest.get('frames')} frames, "
        f"{manifest.get('duration_s')} s)",
        err=True,
    )
    if disk_full is not None:  # the take is kept and indexed, but it is shorter than asked
        typer.echo(f"error: the take stopped early: {disk_full}", err=True)
        raise typer.Exit(1)
