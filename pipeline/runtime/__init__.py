"""Runtime stage: the live, asynchronous multi-process pipeline (processes and shared memory).

The web app uses :class:`Pipeline` (start/stop, status, navigator, workstations,
events, snapshots); ``cavewalk bench`` and ``scripts/soak.py`` measure it.
"""

from pipeline.runtime.config import RuntimeConfig
from pipeline.runtime.pipeline import SOURCES, Pipeline, SimFactory
from pipeline.runtime.stages import (
    Fusion,
    FusionFactory,
    PoseStage,
    PoseStageFactory,
    SimWorldFactory,
    fusion_factory_from_settings,
)
from pipeline.runtime.status import PipelineEvent, PipelineStatus

__all__ = [
    "SOURCES",
    "Fusion",
    "FusionFactory",
    "Pipeline",
    "PipelineEvent",
    "PipelineStatus",
    "PoseStage",
    "PoseStageFactory",
    "RuntimeConfig",
    "SimFactory",
    "SimWorldFactory",
    "fusion_factory_from_settings",
]
