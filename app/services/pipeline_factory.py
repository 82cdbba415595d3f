"""Building the runtime's ``Pipeline`` from the settings (pipeline/ never imports app/).

The settings' sections are the stages' own configs; this module only hands each stage its
section (and the active calibration's cameras).
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from sqlalchemy.orm import Session

from app.core.config import Settings
from app.db.repositories import active_calibration_run
from app.services.calibration import cameras_from_result
from app.services.live import PipelineFacade, PipelineFactory
from pipeline.camera import Camera
from pipeline.recognition.recognizer import RecognizerConfig
from pipeline.runtime.chain import ChainConfig, PoseModel, SimWorldFactory
from pipeline.runtime.config import RuntimeConfig
from pipeline.runtime.pipeline import Handover, Pipeline
from pipeline.sim.config import SimConfig
from pipeline.triangulation.config import ReconstructionConfig

log = logging.getLogger(__name__)


def simulator_factory(settings: Settings, sim: SimConfig | None = None) -> SimWorldFactory:
    """The simulator source of the settings (``sim`` in place of ``settings.sim``)."""
    return SimWorldFactory.build(sim or settings.sim, settings.cave.geometry())


def pose_model(settings: Settings) -> PoseModel:
    """The detector of camera images: the pose section and its model file."""
    return PoseModel(settings.pose, settings.pose_model_path)


def chain_config(settings: Settings, recognition: RecognizerConfig | None = None) -> ChainConfig:
    """The recognition chain's stages from their sections: tracking, triangulation, navigator,
    recognition (``recognition`` in place of the settings' own: the registry's active model),
    head pose, navigation. Its detector and views are the run's (:meth:`ChainConfig.with_views`)."""
    reconstruction = ReconstructionConfig(settings.triangulation, settings.association, settings.tracks3d,
                                          settings.identity)
    return ChainConfig(tracking=settings.tracking, reconstruction=reconstruction,
                       navigator=settings.navigator, recognition=recognition or settings.recognition,
                       head=settings.head, navigation=settings.navigation)


def build_pipeline(settings: Settings, cameras: list[Camera] | None = None,
                   sim: SimWorldFactory | None = None, runtime: RuntimeConfig | None = None,
                   recognition: RecognizerConfig | None = None, handover: Handover | None = None) -> Pipeline:
    """The live pipeline of the settings; ``runtime`` replaces ``settings.runtime`` (benchmarks);
    ``handover``: what the pipeline it replaces carries on (``Pipeline.hand_over``)."""
    return Pipeline(
        runtime or settings.runtime, cameras,
        camera_sources={c.name: c.source for c in settings.cameras},
        chain=chain_config(settings, recognition), pose=pose_model(settings), simulator=sim,
        workstations=settings.endpoints, emitter=settings.emitter,
        status_rate_hz=settings.server.live_rate_hz, handover=handover,
    )


def runtime_factory(
    settings: Settings, session_factory: Callable[[], Session],
    recognition: Callable[[], RecognizerConfig] | None = None,
) -> tuple[PipelineFactory | None, str]:
    """(a function that builds the pipeline, "") or (None, why it cannot be built).

    The pipeline gets the active calibration's cameras (for the real cameras and videos)
    and the simulator's own cameras for the simulator source; ``recognition()`` gives the
    recognition section at each build (the model registry's active model).
    """

    def build(handover: Handover | None = None) -> PipelineFacade:
        with session_factory() as db:
            run = active_calibration_run(db)
            cameras = cameras_from_result(run.result) if run is not None and run.result else None
        rec = recognition() if recognition is not None else None
        return build_pipeline(settings, cameras, simulator_factory(settings), recognition=rec,
                              handover=handover)

    return build, ""
