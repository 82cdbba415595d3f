"""Takes: record from the running pipeline, list, read their files; the shipped protocols."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Literal

from fastapi import APIRouter, Depends, HTTPException, Query, status
from fastapi.requests import HTTPConnection
from fastapi.responses import FileResponse
from starlette.background import BackgroundTask

from app.api.deps import IdPath, SessionDep
from app.db.errors import StateConflict
from app.db.take_repository import get_take, list_takes, update_take_files
from app.schemas.takes import (
    LabelsPublic,
    LabelsUpdate,
    ProtocolPublic,
    RecordingPublic,
    ReplayPublic,
    ReplayRequest,
    TakeCreate,
    TakePublic,
)
from app.services.recorder import TakeRequest
from pipeline.errors import InputError
from pipeline.takes.export import take_trc, write_export
from pipeline.takes.files import LABELS, read_spans, relabel_take
from pipeline.takes.protocol import LabelSpan, load_protocol, shipped_protocols

if TYPE_CHECKING:
    from app.services.recorder import RecorderService
    from app.services.replay import TakeReplay


def get_recorder(conn: HTTPConnection) -> RecorderService:
    service: RecorderService = conn.app.state.recorder
    return service


RecorderDep = Annotated["RecorderService", Depends(get_recorder)]


def get_replay(conn: HTTPConnection) -> TakeReplay:
    replay: TakeReplay = conn.app.state.replay
    return replay


ReplayDep = Annotated["TakeReplay", Depends(get_replay)]

router = APIRouter(tags=["takes"])


@router.get("/protocols", response_model=list[ProtocolPublic])
def protocols() -> list[ProtocolPublic]:
    out = []
    for stem, path in shipped_protocols().items():
        p = load_protocol(path).to_dict()
        out.append(ProtocolPublic(file=stem, **p))
    return out


@router.get("/takes", response_model=list[TakePublic])
def takes(db: SessionDep, participant_code: str | None = None) -> list[TakePublic]:
    return [TakePublic.model_validate(t) for t in list_takes(db, participant_code)]


@router.post(
    "/takes",
    response_model=TakePublic,
    status_code=status.HTTP_201_CREATED,
    responses={409: {"description": "The pipeline is not running, or a take is recording"}},
)
def start_take(body: TakeCreate, recorder: RecorderDep) -> TakePublic:
    row = recorder.start(TakeRequest(**body.model_dump()))
    return TakePublic.model_validate(row)


@router.get("/takes/current", response_model=RecordingPublic)
def current_take(recorder: RecorderDep) -> RecordingPublic:
    cur = recorder.current()
    return RecordingPublic(recording=False) if cur is None else RecordingPublic(recording=True, **cur)


@router.delete("/takes/replay", status_code=status.HTTP_204_NO_CONTENT)
def stop_replay(replay: ReplayDep) -> None:
    """The 3D view shows the live people again."""
    replay.stop()


@router.get("/takes/{take_id}", response_model=TakePublic)
def take(take_id: IdPath, db: SessionDep) -> TakePublic:
    return TakePublic.model_validate(get_take(db, take_id))


@router.post(
    "/takes/{take_id}/stop",
    response_model=TakePublic,
    responses={409: {"description": "The take is not recording"}},
)
def stop_take(take_id: IdPath, recorder: RecorderDep) -> TakePublic:
    return TakePublic.model_validate(recorder.stop(take_id))


@router.get(
    "/takes/{take_id}/files/{name:path}",
    response_class=FileResponse,
    responses={404: {"description": "No such take, or no such file in it"}},
)
def take_file(take_id: IdPath, name: str, db: SessionDep) -> FileResponse:
    row = get_take(db, take_id)
    if name not in (row.files or {}) and name != "take.json":  # only the files the index lists
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"take {take_id} has no file {name!r}")
    path = Path(row.folder) / name
    if not path.is_file():
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"take {take_id}: {name} is missing from its folder")
    return FileResponse(path, filename=Path(name).name)


@router.get(
    "/takes/{take_id}/export",
    response_class=FileResponse,
    responses={
        400: {"description": "The take's folder is damaged (files missing or changed)"},
        404: {"description": "No such take"},
        409: {"description": "The take is still recording"},
        422: {"description": "A bad format or user, or labels asked of a take without labels"},
    },
)
def export_take(
    take_id: IdPath,
    db: SessionDep,
    fmt: Annotated[
        Literal["zip", "trc", "labels"],
        Query(alias="format", description="zip: the take's files + videos + TRC + labels table; trc: one "
              "person's markers (metres, Y-up, Pose2Sim/OpenSim); labels: one CSV row per frame"),
    ] = "zip",
    user_id: Annotated[int | None, Query(ge=0, le=2**31, description="trc: the person (default: "
                                         "the participant)")] = None,
) -> FileResponse:
    """Download the take exported (built on request from its verified files; nothing stored changes)."""
    row = get_take(db, take_id)
    if row.status == "recording":
        raise StateConflict(f"take {take_id} is still recording; export it once it has ended")
    if user_id is not None and fmt != "trc":
        raise InputError("user_id is for format=trc (the zip holds every person's TRC)")
    tmp = Path(tempfile.mkdtemp(prefix="cavewalk-export-"))
    try:
        if fmt == "trc":
            name, text = take_trc(Path(row.folder), user_id)
            (tmp / name).write_text(text, encoding="utf-8")
        else:
            name = f"{row.uid}.zip" if fmt == "zip" else f"{row.uid}_labels.csv"
            write_export(Path(row.folder), tmp / name, fmt)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    media = {"zip": "application/zip", "trc": "text/plain", "labels": "text/csv"}[fmt]
    return FileResponse(tmp / name, filename=name, media_type=media,
                        background=BackgroundTask(shutil.rmtree, tmp, ignore_errors=True))


@router.put(
    "/takes/{take_id}/replay",
    response_model=ReplayPublic,
    responses={409: {"description": "The take is still recording, or the 3D view is off"}},
)
def replay_take(take_id: IdPath, body: ReplayRequest, db: SessionDep, replay: ReplayDep) -> ReplayPublic:
    """Show the take's frame at ``t_s`` in the 3D view (in place of the live people, until
    DELETE /takes/replay or two minutes without another)."""
    row = get_take(db, take_id)
    if row.status == "recording":
        raise StateConflict(f"take {take_id} is still recording; replay it once it has ended")
    return ReplayPublic(**replay.show(row.id, Path(row.folder), row.files or {}, body.t_s))


def _spans_out(spans: list[LabelSpan]) -> list[dict[str, object]]:
    return [{"t_start": sp.t_start, "t_end": sp.t_end, "label": sp.label, "user_id": sp.user_id,
             "source": sp.source, "tag": sp.tag} for sp in spans]


@router.get("/takes/{take_id}/labels", response_model=LabelsPublic)
def take_labels(take_id: IdPath, db: SessionDep) -> LabelsPublic:
    row = get_take(db, take_id)
    spans = read_spans(Path(row.folder) / LABELS)
    return LabelsPublic(take_id=row.id, duration_s=row.duration_s, spans=_spans_out(spans))


@router.put("/takes/{take_id}/labels", response_model=LabelsPublic,
            responses={409: {"description": "The take is still recording"}})
def set_take_labels(take_id: IdPath, body: LabelsUpdate, db: SessionDep) -> LabelsPublic:
    """Replace the take's label spans (the timeline editor): labels.csv, the NPZ labels, the checksums."""
    row = get_take(db, take_id)
    if row.status == "recording":
        raise StateConflict(f"take {take_id} is still recording; stop it before editing its labels")
    limit = (row.duration_s or 0.0) + 1.0
    spans = []
    for i, sp in enumerate(body.spans):
        if sp.t_end > limit:
            raise InputError(f"span {i + 1}: t_end {sp.t_end} is past the take's end ({row.duration_s} s)")
        try:
            spans.append(LabelSpan(sp.t_start, sp.t_end, sp.label, sp.user_id, sp.source, sp.tag))
        except InputError as exc:
            raise InputError(f"span {i + 1}: {exc}") from None
    manifest = relabel_take(Path(row.folder), spans)
    update_take_files(db, take_id, manifest["files"])
    return LabelsPublic(take_id=row.id, duration_s=row.duration_s, spans=_spans_out(spans))
