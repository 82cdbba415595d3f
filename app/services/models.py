"""The registry of action models: files in the models data folder, indexed in SQLite.

Models are versioned like calibrations: every model file cavewalk may run is a row of
``action_models`` with its card; one is active, and the pipeline is built with it (the next
pipeline start after a change). The committed model (``pipeline/recognition/action.onnx``) is
always there as the ``base`` entry. A file that is not a four-class action model, or whose card
does not match it, is refused (:func:`pipeline.takes.model_file.check_model_file`) before anything
is copied or stored.
"""

from __future__ import annotations

import json
import logging
import secrets
import shutil
from collections.abc import Callable
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from sqlalchemy.orm import Session

from app.core.config import Settings
from app.db import model_repository as repo
from app.db.errors import StateConflict
from app.db.models import ActionModel, Adaptation
from app.db.take_repository import get_take
from app.services.event_log import EventWriter
from pipeline.errors import InputError
from pipeline.recognition.recognizer import DEFAULT_MODEL_PATH, RecognizerConfig, open_session
from pipeline.takes.dataset import load_take
from pipeline.takes.model_file import check_model_file, sha256_file
from pipeline.takes.teach import METHOD, OutputAdaptation, fit_adaptation

log = logging.getLogger(__name__)

BASE_UID = "base"
MODEL_FILE = "action.onnx"
CARD_JSON = "card.json"
CARD_MD = "MODEL_CARD.md"
BASE_CARD_MD = DEFAULT_MODEL_PATH.parent / "MODEL_CARD.md"


def models_folder(settings: Settings) -> Path:
    """The models data folder: ``action-models/`` beside the database."""
    return settings.paths.db.parent / "action-models"


def model_public(row: ActionModel) -> dict[str, Any]:
    return {
        "id": row.id,
        "uid": row.uid,
        "name": row.name,
        "kind": row.kind,
        "sha256": row.sha256,
        "parent_id": row.parent_id,
        "created_at": row.created_at,
        "active": row.active,
        "activated_at": row.activated_at,
        "card": row.card,
        "notes": row.notes,
    }


def adaptation_public(row: Adaptation) -> dict[str, Any]:
    return {"id": row.id, "participant_code": row.participant_code, "model_id": row.model_id,
            "take_id": row.take_id, "created_at": row.created_at, "enabled": row.enabled,
            "method": row.method, "report": row.report}  # fmt: skip


def ensure_base(db: Session) -> ActionModel:
    """The committed model's row (created, or its checksum and card brought up to date), and an active
    model (the base when none is)."""
    info = check_model_file(DEFAULT_MODEL_PATH)
    card_md = BASE_CARD_MD.read_text(encoding="utf-8") if BASE_CARD_MD.is_file() else ""
    card = {**info.to_dict(), "source": "committed with cavewalk (pipeline/recognition/action.onnx)"}
    row = repo.base_model(db)
    if row is None:
        row = repo.add_model(
            db, uid=BASE_UID, name="committed action.onnx", kind="base", file=str(DEFAULT_MODEL_PATH),
            sha256=info.sha256, card=card, card_md=card_md,
        )  # fmt: skip
    elif row.sha256 != info.sha256 or row.file != str(DEFAULT_MODEL_PATH):
        row.sha256, row.file, row.card, row.card_md = info.sha256, str(DEFAULT_MODEL_PATH), card, card_md
        db.commit()
    if repo.active_model(db) is None:
        row = repo.make_active(db, row.id)
    return row


class ModelService:
    """Registers, lists, activates and rolls back action models; knows which one the pipeline runs."""

    def __init__(
        self,
        settings: Settings,
        session_factory: Callable[[], Session],
        events: EventWriter | None = None,
        models_changed: Callable[[], None] = lambda: None,
    ) -> None:
        self.settings = settings
        self.folder = models_folder(settings)
        self._factory = session_factory
        self._events = events
        self._models_changed = models_changed
        self.running: dict[str, Any] | None = None  # the model the pipeline was last built with
        self._apply_adaptation: Callable[[OutputAdaptation | None], None] = lambda _a: None
        self._session_participant: str | None = None
        with self._factory() as db:
            ensure_base(db)

    # ----------------------------------------------------------------------------------- reads
    def all_models(self) -> list[dict[str, Any]]:
        with self._factory() as db:
            return [model_public(r) for r in repo.list_models(db)]

    def get(self, model_id: int) -> dict[str, Any]:
        with self._factory() as db:
            return model_public(repo.get_model(db, model_id))

    def file_of(self, model_id: int) -> str:
        """The model's file (checked: there and unchanged)."""
        with self._factory() as db:
            row = repo.get_model(db, model_id)
            self._check_on_disk(row)
            return row.file

    def card_markdown(self, model_id: int) -> str:
        with self._factory() as db:
            return repo.get_model(db, model_id).card_md

    def active(self) -> dict[str, Any]:
        with self._factory() as db:
            row = repo.active_model(db) or ensure_base(db)
            return model_public(row) | {"file": row.file}

    @property
    def settings_override(self) -> bool:
        """True when the settings name a model file themselves (``recognition.model_path``): it wins."""
        return Path(self.settings.recognition.model_path) != DEFAULT_MODEL_PATH

    def recognition_config(self) -> RecognizerConfig:
        """The settings' recognition section with the active model (unless the settings name one);
        remembered as the model the pipeline runs."""
        config = self.settings.recognition
        if self.settings_override:
            self.running = {"id": None, "file": str(config.model_path), "source": "settings"}
            return config
        active = self.active()
        self.running = {"id": active["id"], "uid": active["uid"], "sha256": active["sha256"],
                        "file": active["file"], "source": "registry"}  # fmt: skip
        return replace(config, model_path=Path(active["file"]))

    def session_context(self) -> dict[str, Any]:
        """What a study session's log records of the action model: the active one and the running one."""
        active = self.active()
        return {
            "action_model_id": active["id"],
            "action_model_name": active["name"],
            "action_model_uid": active["uid"],
            "action_model_sha256": active["sha256"],
            "action_model_running": self.running,
        }

    def on_change(self, callback: Callable[[], None]) -> None:
        """``callback()`` whenever another model becomes active (the pipeline rebuilds at its next start)."""
        self._models_changed = callback

    def changed(self) -> None:
        """Another model became active elsewhere (a training job's worker): rebuild at the next start."""
        self._models_changed()

    def stale(self) -> bool:
        """True when the pipeline was built with another model than the active one (activated elsewhere,
        e.g. by the command line)."""
        if self.running is None or self.settings_override:
            return False
        return self.running.get("id") != self.active()["id"]

    # ---------------------------------------------------------------------------------- writes
    def register(
        self,
        path: Path,
        *,
        card: dict[str, Any] | None = None,
        card_md: str = "",
        name: str | None = None,
        kind: str = "uploaded",
        parent_id: int | None = None,
        notes: str = "",
    ) -> dict[str, Any]:
        """Check and copy a model file (and its card) into the models folder and index it; nothing is
        stored when the file is refused."""
        info = check_model_file(Path(path), card)
        with self._factory() as db:
            same = repo.model_with_sha(db, info.sha256)
            if same is not None:
                raise StateConflict(f"this model file is already registered as model {same.id} ({same.name})")
            if parent_id is not None:
                repo.get_model(db, parent_id)
        now = datetime.now(UTC)
        uid = f"{now:%Y%m%d-%H%M%S}-{info.sha256[:8]}-{secrets.token_hex(2)}"
        folder = self.folder / uid
        tmp = self.folder / f".{uid}.tmp"
        full_card = {**(card or {}), **info.to_dict()}
        try:
            tmp.mkdir(parents=True)
            shutil.copyfile(path, tmp / MODEL_FILE)
            if sha256_file(tmp / MODEL_FILE) != info.sha256:
                raise InputError(f"{path}: the file changed while it was copied")
            card_text = json.dumps(full_card, indent=1, default=str) + "\n"
            (tmp / CARD_JSON).write_text(card_text, encoding="utf-8")
            (tmp / CARD_MD).write_text(card_md, encoding="utf-8")
            tmp.rename(folder)
            with self._factory() as db:
                row = repo.add_model(
                    db, uid=uid, name=(name or Path(path).name)[:128], kind=kind,
                    file=str(folder / MODEL_FILE),
                    sha256=info.sha256, parent_id=parent_id, card=full_card, card_md=card_md, notes=notes,
                )  # fmt: skip
                out = model_public(row)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            shutil.rmtree(folder, ignore_errors=True)
            raise
        self._record("registered", out)
        return out

    def activate(self, model_id: int) -> dict[str, Any]:
        """Make a model the active one; its file must still be there and unchanged."""
        with self._factory() as db:
            row = repo.get_model(db, model_id)
            self._check_on_disk(row)
            before = repo.active_model(db)
            row = repo.make_active(db, row.id)
            out = model_public(row)
        self._record("activated", out, previous=before.id if before is not None else None)
        self._models_changed()
        return out

    def rollback(self) -> dict[str, Any]:
        """Activate the model that was active before the active one."""
        with self._factory() as db:
            target = repo.previous_model(db).id
        return self.activate(target)

    # ----------------------------------------------------------------------------------- teach
    def on_adaptation(self, apply: Callable[[OutputAdaptation | None], None]) -> None:
        """``apply(adaptation)`` puts a participant's adaptation on the running recogniser (None: off)."""
        self._apply_adaptation = apply

    def teach(self, take_id: int, holdout_fraction: float = 0.34) -> dict[str, Any]:
        """Fit the take's participant's adaptation of the active model on the take (issue 18 item 3);
        switched on when it does no worse on the held-back part; applied now if their session runs."""
        with self._factory() as db:
            take = get_take(db, take_id)
            if take.status == "recording":
                raise StateConflict(f"take {take_id} is still recording")
            code, folder = take.participant_code, Path(take.folder)
        if not code:
            raise InputError(
                f"take {take_id} has no participant code: teach adapts the recogniser to one person"
            )
        data = load_take(folder)
        active = self.active()
        config = replace(self.settings.recognition, model_path=Path(active["file"]))
        result = fit_adaptation(open_session(config.model_path), data.seq, config, holdout_fraction)
        with self._factory() as db:
            row = repo.add_adaptation(
                db,
                participant_code=code,
                model_id=active["id"],
                take_id=take_id,
                enabled=False,
                method=METHOD,
                params=result.adaptation.params(),
                report=result.report(),
            )
            if result.helps:
                row = repo.set_adaptation_enabled(db, row.id, True)
            out = adaptation_public(row)
        self._record_adaptation("fitted", out)
        self._reapply(code)
        return out

    def adaptations(self, participant_code: str | None = None) -> list[dict[str, Any]]:
        with self._factory() as db:
            return [adaptation_public(r) for r in repo.list_adaptations(db, participant_code)]

    def set_adaptation_enabled(self, adaptation_id: int, enabled: bool) -> dict[str, Any]:
        with self._factory() as db:
            out = adaptation_public(repo.set_adaptation_enabled(db, adaptation_id, enabled))
        self._record_adaptation("switched on" if enabled else "switched off", out)
        self._reapply(out["participant_code"])
        return out

    def adaptation_for(self, participant_code: str | None) -> OutputAdaptation | None:
        """The participant's adaptation of the active model that is switched on (None: none)."""
        if participant_code is None or self.settings_override:
            return None
        with self._factory() as db:
            active = repo.active_model(db)
            row = repo.enabled_adaptation(db, participant_code, active.id) if active is not None else None
            if row is None:
                return None
            return OutputAdaptation.from_params(row.params, adaptation_id=row.id,
                                                participant_code=participant_code)  # fmt: skip

    def teach_context(self, participant_code: str | None) -> dict[str, Any]:
        """What a session's start event records of the participant's adaptation."""
        a = self.adaptation_for(participant_code)
        if a is None:
            return {"teach_adaptation_id": None}
        with self._factory() as db:
            report = repo.get_adaptation(db, a.adaptation_id or 0).report
        return {"teach_adaptation_id": a.adaptation_id, "teach_method": report.get("method"),
                "teach_before": (report.get("before") or {}).get("accuracy"),
                "teach_after": (report.get("after") or {}).get("accuracy")}  # fmt: skip

    def session_started(self, participant_code: str | None) -> None:
        """A study session of this participant runs: their adaptation (if on) goes on the recogniser."""
        self._session_participant = participant_code
        self._apply_adaptation(self.adaptation_for(participant_code))

    def session_stopped(self) -> None:
        """The session ended: the recogniser goes back to the model alone."""
        self._session_participant = None
        self._apply_adaptation(None)

    def _reapply(self, participant_code: str | None) -> None:
        if participant_code is not None and participant_code == self._session_participant:
            self._apply_adaptation(self.adaptation_for(participant_code))

    def _record_adaptation(self, state: str, a: dict[str, Any]) -> None:
        if self._events is not None:
            rep = a["report"]
            self._events.record(
                "adaptation", {"state": state, "adaptation_id": a["id"], "participant": a["participant_code"],
                               "model_id": a["model_id"], "enabled": a["enabled"],
                               "before": (rep.get("before") or {}).get("accuracy"),
                               "after": (rep.get("after") or {}).get("accuracy")},
            )  # fmt: skip

    # --------------------------------------------------------------------------------- helpers
    def _check_on_disk(self, row: ActionModel) -> None:
        path = Path(row.file)
        if not path.is_file():
            raise StateConflict(f"model {row.id}: its file {path} is missing; it cannot be activated")
        if sha256_file(path) != row.sha256:
            raise StateConflict(f"model {row.id}: its file {path} changed since it was registered (sha256)")

    def _record(self, state: str, model: dict[str, Any], **extra: Any) -> None:
        if self._events is not None:
            self._events.record(
                "model", {"state": state, "model_id": model["id"], "uid": model["uid"],
                          "sha256": model["sha256"], **extra},
            )  # fmt: skip
