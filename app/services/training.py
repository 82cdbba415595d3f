"""Fine-tuning jobs of the dashboard: ``cavewalk train`` run in a worker process, its progress kept.

:meth:`TrainingService.start` checks everything first (the ``train`` extra, the takes: indexed,
finished, labelled; one job at a time) and answers at once; the worker is the command line's own
``cavewalk train --progress-json`` in a child process (torch never runs in the server's process),
which registers the model in the same database. The job's state, progress and log lines are kept in
memory (a server restart forgets them; the registered model stays).
"""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from sqlalchemy.orm import Session

from app.core.config import Settings
from app.db.errors import StateConflict
from app.db.take_repository import get_take
from app.services.models import ModelService
from pipeline.errors import InputError
from pipeline.takes.dataset import load_take
from pipeline.takes.finetune import require_training

log = logging.getLogger(__name__)
REPO_ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True, slots=True)
class TrainRequest:
    take_ids: tuple[int, ...]
    epochs: int = 2
    sim_routines: int = 8
    windows_per_epoch: int = 4096
    loso: bool = True
    activate: bool = False
    sim_duration_s: float = 12.0
    heldout_routines: int = 2


@dataclass
class TrainJob:
    id: int
    state: str = "running"
    progress: float = 0.0
    message: str = "starting"
    log: list[str] = field(default_factory=list)
    model_id: int | None = None
    started_at: datetime = field(default_factory=lambda: datetime.now(UTC))
    ended_at: datetime | None = None
    process: subprocess.Popen[str] | None = None
    out: Path | None = None  # the worker's file; the registry keeps its own copy

    def public(self) -> dict[str, Any]:
        return {"id": self.id, "state": self.state, "progress": self.progress, "message": self.message,
                "log": self.log[-50:], "model_id": self.model_id, "started_at": self.started_at,
                "ended_at": self.ended_at}  # fmt: skip


class TrainingService:
    """At most one fine-tuning job at a time; its worker is ``cavewalk train`` in a child process."""

    def __init__(
        self, settings: Settings, session_factory: Callable[[], Session], models: ModelService
    ) -> None:
        self.settings = settings
        self._factory = session_factory
        self._models = models
        self._lock = threading.Lock()
        self._jobs: dict[int, TrainJob] = {}

    def start(self, req: TrainRequest) -> dict[str, Any]:
        require_training()  # TrainingUnavailable (400) names the extra to install
        folders = []
        with self._factory() as db:
            for take_id in req.take_ids:
                row = get_take(db, take_id)
                if row.status == "recording":
                    raise StateConflict(f"take {take_id} is still recording")
                folders.append(Path(row.folder))
        for take_id, folder in zip(req.take_ids, folders, strict=True):
            try:
                load_take(folder)  # no labels, missing files: refused now, not in the worker
            except InputError as exc:
                raise InputError(f"take {take_id}: {exc}") from None
        with self._lock:
            if any(j.state == "running" for j in self._jobs.values()):
                raise StateConflict("a fine-tuning job is running; wait for it to end")
            job = TrainJob(id=len(self._jobs) + 1)
            out = self._models.folder / ".train" / f"job-{job.id}-{job.started_at:%Y%m%d-%H%M%S}.onnx"
            out.parent.mkdir(parents=True, exist_ok=True)
            cmd = [sys.executable, "-m", "app.cli", "train", "--out", str(out),
                   "--db", str(self.settings.paths.db),
                   "--epochs", str(req.epochs), "--sim", str(req.sim_routines),
                   "--windows-per-epoch", str(req.windows_per_epoch), "--progress-json",
                   "--sim-duration", str(req.sim_duration_s), "--heldout", str(req.heldout_routines),
                   "--loso" if req.loso else "--no-loso", *(["--activate"] if req.activate else []),
                   "--takes", *map(str, folders)]  # fmt: skip
            env = os.environ | {"CAVEWALK_PATHS__CACHE_DIR": str(self.settings.paths.cache_dir)}
            job.process = subprocess.Popen(cmd, cwd=REPO_ROOT, env=env, stdout=subprocess.PIPE,
                                           stderr=subprocess.PIPE, text=True)  # fmt: skip
            job.out = out
            self._jobs[job.id] = job
        threading.Thread(
            target=self._follow, args=(job, req), name=f"train-job-{job.id}", daemon=True
        ).start()
        return job.public()

    def get(self, job_id: int) -> dict[str, Any]:
        with self._lock:
            job = self._jobs.get(job_id)
        if job is None:
            from app.db.errors import RecordNotFound

            raise RecordNotFound(f"training job {job_id} not found")
        return job.public()

    def list(self) -> list[dict[str, Any]]:
        with self._lock:
            return [j.public() for j in self._jobs.values()]

    def _follow(self, job: TrainJob, req: TrainRequest) -> None:
        proc = job.process
        assert proc is not None and proc.stdout is not None and proc.stderr is not None
        stderr: list[str] = []
        drain = threading.Thread(target=lambda: stderr.extend(proc.stderr or []), daemon=True)
        drain.start()
        for line in proc.stdout:
            try:
                msg = json.loads(line)
            except ValueError:
                continue
            if "progress" in msg:
                job.progress, job.message = float(msg["progress"]), str(msg["message"])
                job.log.append(job.message)
            elif "done" in msg:
                job.model_id = msg["done"].get("model_id")
        code = proc.wait()
        drain.join(timeout=5)
        job.ended_at = datetime.now(UTC)
        if code == 0 and job.model_id is not None:
            job.state, job.progress, job.message = "done", 1.0, f"registered as model {job.model_id}"
            if job.out is not None:  # registered: the registry's folder holds the model and its card
                for p in (job.out, job.out.with_suffix(".json"), job.out.with_suffix(".md")):
                    p.unlink(missing_ok=True)
            if req.activate:
                self._models.changed()
        else:
            errors = [ln.strip() for ln in stderr if ln.startswith("error:")]
            job.state = "failed"
            job.message = errors[-1] if errors else f"the training worker ended with status {code}"
            job.log += [ln.rstrip() for ln in stderr[-20:]]
            log.warning("training job %d failed: %s", job.id, job.message)

    def close(self) -> None:
        with self._lock:
            jobs = list(self._jobs.values())
        for job in jobs:
            if job.process is not None and job.process.poll() is None:
                job.process.terminate()
