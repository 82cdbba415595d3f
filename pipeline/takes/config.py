"""The settings' ``[takes]`` section."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True, slots=True)
class TakesConfig:
    """Where takes go and how they are written.

    folder: the data folder of takes (None: ``takes/`` beside the database).
    flush_interval_s: the frames written so far reach the disk at least this often (at most 1 s:
        the most a crash can lose).
    queue_frames: frames held between the pipeline and the writer (when full, the oldest is dropped
        and counted: recording never blocks the pipeline).
    margin_s: the default reaction margin, seconds labelled ``ignore`` after every change of a
        protocol's label; lead_s: the same before it.
    max_duration_s: the longest take.
    """

    folder: Path | None = None
    flush_interval_s: float = 0.5
    queue_frames: int = 1200
    margin_s: float = 0.5
    lead_s: float = 0.0
    max_duration_s: float = 3600.0

    def __post_init__(self) -> None:
        if not 0 < self.flush_interval_s <= 1.0:
            raise ValueError(f"flush_interval_s must be in (0, 1], got {self.flush_interval_s}")
        if self.queue_frames < 10:
            raise ValueError(f"queue_frames must be >= 10, got {self.queue_frames}")
        for name in ("margin_s", "lead_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and 0 <= v <= 5):
                raise ValueError(f"{name} must be in [0, 5] seconds, got {v}")
        if not 1 <= self.max_duration_s <= 86400:
            raise ValueError(f"max_duration_s must be in [1, 86400], got {self.max_duration_s}")
