"""The user study's one frozen config: the settings' ``[study]`` section (design and analysis).

No heavy imports here: the design (:mod:`app.study.design`) and the analysis (:mod:`app.study.analysis`)
work on the database's rows (:mod:`app.study.data`, SQLAlchemy).
"""

from __future__ import annotations

from dataclasses import dataclass, field

CORRECTIONS: tuple[str, ...] = ("holm", "bonferroni", "none")


@dataclass(frozen=True, slots=True)
class AnalysisConfig:
    """alpha: significance level. correction: for multiple comparisons over the tested measures.
    normality_min_n: below this many pairs Shapiro-Wilk is said to be underpowered."""

    alpha: float = 0.05
    correction: str = "holm"
    normality_min_n: int = 10

    def __post_init__(self) -> None:
        if not 0 < self.alpha < 1:
            raise ValueError(f"alpha must be in (0, 1), got {self.alpha}")
        if self.correction not in CORRECTIONS:
            raise ValueError(f"correction must be one of {CORRECTIONS}, got {self.correction!r}")
        if self.normality_min_n < 3:
            raise ValueError(f"normality_min_n must be >= 3, got {self.normality_min_n}")


@dataclass(frozen=True, slots=True)
class DesignConfig:
    min_gap_days: float = 2.0

    def __post_init__(self) -> None:
        if self.min_gap_days < 0:
            raise ValueError(f"min_gap_days must be >= 0, got {self.min_gap_days}")


@dataclass(frozen=True, slots=True)
class StudyConfig:
    """design: ``[study.design]`` (the gap between a participant's sessions); analysis:
    ``[study.analysis]`` (the significance level); hold_controller_sessions: a controller (``CC``)
    session holds navigation while it runs (every locomotion datagram says ``still``), so that the
    participant's steps never move the walls in the condition whose navigation is the controller."""

    design: DesignConfig = field(default_factory=DesignConfig)
    analysis: AnalysisConfig = field(default_factory=AnalysisConfig)
    hold_controller_sessions: bool = True
