"""Action models: the registry (list with cards, upload, activate, roll back), training jobs, teach."""

from __future__ import annotations

import base64
import binascii
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

from fastapi import APIRouter, Depends, Response, status
from fastapi.requests import HTTPConnection

from app.api.deps import IdPath
from app.schemas.models import (
    AdaptationPublic,
    AdaptationUpdate,
    ModelPublic,
    ModelUpload,
    TeachCreate,
    TrainCreate,
    TrainJobPublic,
)
from app.services.training import TrainRequest
from pipeline.errors import InputError

if TYPE_CHECKING:
    from app.services.models import ModelService
    from app.services.training import TrainingService


def get_models(conn: HTTPConnection) -> ModelService:
    service: ModelService = conn.app.state.models
    return service


def get_training(conn: HTTPConnection) -> TrainingService:
    service: TrainingService = conn.app.state.training
    return service


ModelsDep = Annotated["ModelService", Depends(get_models)]
TrainingDep = Annotated["TrainingService", Depends(get_training)]

router = APIRouter(prefix="/models", tags=["models"])


@router.get("", response_model=list[ModelPublic])
def list_models(models: ModelsDep) -> list[dict[str, Any]]:
    """Every registered model with its card (the committed model is the ``base`` entry)."""
    return models.all_models()


@router.get("/active", response_model=ModelPublic)
def active_model(models: ModelsDep) -> dict[str, Any]:
    return models.active()


@router.post(
    "",
    response_model=ModelPublic,
    status_code=status.HTTP_201_CREATED,
    responses={
        400: {"description": "Not a four-class action model, or its card does not match it"},
        409: {"description": "This file is registered already"},
    },
)
def upload_model(body: ModelUpload, models: ModelsDep) -> dict[str, Any]:
    """Register a model file (base64 ONNX) with its card; a refused file stores nothing."""
    try:
        data = base64.b64decode(body.onnx_base64, validate=True)
    except (binascii.Error, ValueError):
        raise InputError("onnx_base64 is not base64 text") from None
    with tempfile.TemporaryDirectory(prefix="cavewalk-upload-") as tmp:
        path = Path(tmp) / "upload.onnx"
        path.write_bytes(data)
        return models.register(
            path, card=body.card, card_md=body.card_md, name=body.name, kind="uploaded", notes=body.notes
        )


@router.post(
    "/train",
    response_model=TrainJobPublic,
    status_code=status.HTTP_202_ACCEPTED,
    responses={
        400: {"description": "The train extra is missing, or a take has no labels"},
        409: {"description": "A job is running, or a take is still recording"},
    },
)
def start_training(body: TrainCreate, training: TrainingDep) -> dict[str, Any]:
    """Fine-tune the active model on labelled takes (+ simulator data) in a worker; poll the job."""
    req = TrainRequest(tuple(body.take_ids), body.epochs, body.sim_routines, body.windows_per_epoch,
                       body.loso, body.activate, body.sim_duration_s, body.heldout_routines)  # fmt: skip
    return training.start(req)


@router.get("/train", response_model=list[TrainJobPublic])
def training_jobs(training: TrainingDep) -> list[dict[str, Any]]:
    return training.list()


@router.get("/train/{job_id}", response_model=TrainJobPublic)
def training_job(job_id: IdPath, training: TrainingDep) -> dict[str, Any]:
    return training.get(job_id)


@router.post(
    "/teach",
    response_model=AdaptationPublic,
    status_code=status.HTTP_201_CREATED,
    responses={
        409: {"description": "The take is still recording"},
        422: {"description": "The take has no participant, no labels, or too few actions"},
    },
)
def teach(body: TeachCreate, models: ModelsDep) -> dict[str, Any]:
    """Adapt the active model to the participant of a teach take; reports accuracy before / after on the
    held-back part of the take; switched on when it does no worse there; applies to their sessions."""
    return models.teach(body.take_id, body.holdout_fraction)


@router.get("/adaptations", response_model=list[AdaptationPublic])
def adaptations(models: ModelsDep, participant_code: str | None = None) -> list[dict[str, Any]]:
    return models.adaptations(participant_code)


@router.patch("/adaptations/{adaptation_id}", response_model=AdaptationPublic)
def switch_adaptation(adaptation_id: IdPath, body: AdaptationUpdate, models: ModelsDep) -> dict[str, Any]:
    """Switch a participant's adaptation on (their others off) or off; at once if their session runs."""
    return models.set_adaptation_enabled(adaptation_id, body.enabled)


@router.get("/{model_id}", response_model=ModelPublic)
def get_model(model_id: IdPath, models: ModelsDep) -> dict[str, Any]:
    return models.get(model_id)


@router.get(
    "/{model_id}/card.md", response_class=Response, responses={200: {"content": {"text/markdown": {}}}}
)
def model_card(model_id: IdPath, models: ModelsDep) -> Response:
    """The model card as Markdown."""
    return Response(models.card_markdown(model_id), media_type="text/markdown; charset=utf-8")


@router.post(
    "/{model_id}/activate",
    response_model=ModelPublic,
    responses={409: {"description": "The model's file is missing or changed"}},
)
def activate_model(model_id: IdPath, models: ModelsDep) -> dict[str, Any]:
    """Make the model the active one; the pipeline runs it from its next start."""
    return models.activate(model_id)


@router.post(
    "/rollback",
    response_model=ModelPublic,
    responses={409: {"description": "No model was active before this one"}},
)
def rollback_model(models: ModelsDep) -> dict[str, Any]:
    """Activate the model that was active before the active one."""
    return models.rollback()
