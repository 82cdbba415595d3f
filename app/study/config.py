"""The user study's one frozen config: the settings' ``[study]`` section (design and analysis)."""

from __future__ import annotations

from dataclasses import dataclass, field

from app.study.analysis import AnalysisConfig
from app.study.design import DesignConfig


@dataclass(frozen=True, slots=True)
class StudyConfig:
    """design: ``[study.design]`` (the gap between a participant's sessions); analysis:
    ``[study.analysis]`` (the significance level); hold_controller_sessions: a controller (``CC``)
    session holds navigation while it runs (every locomotion datagram says ``still``), so that the
    participant's steps never move the walls in the condition whose navigation is the controller."""

    design: DesignConfig = field(default_factory=DesignConfig)
    analysis: AnalysisConfig = field(default_factory=AnalysisConfig)
    hold_controller_sessions: bool = True
