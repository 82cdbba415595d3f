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
    video_*: the camera videos a take may record (:mod:`pipeline.takes.video`): the encoder
        (``video_codec``, ``video_preset``, ``video_crf``, ``video_threads``), frames scaled to
        ``video_long_side`` pixels on their long side (None: as captured), ``video_queue_frames``
        held for the encoder in each capture worker (the oldest is dropped and counted when it
        falls behind), and how long the end of a take waits for the files to be closed.
    """

    folder: Path | None = None
    flush_interval_s: float = 0.5
    queue_frames: int = 1200
    margin_s: float = 0.5
    lead_s: float = 0.0
    max_duration_s: float = 3600.0
    video_codec: str = "libx264"
    video_preset: str = "ultrafast"
    video_crf: int = 23
    video_long_side: int | None = None
    video_queue_frames: int = 16
    video_threads: int = 1
    video_stop_timeout_s: float = 15.0

    def __post_init__(self) -> None:
        if not 0 < self.flush_interval_s <= 1.0:
            raise ValueError(f"flush_interval_s must be in (0, 1], got {self.flush_interval_s}")
        if self.queue_frames < 10:
            raise ValueError(f"queue_frames must be >= 10, got {self.queue_frames}")
        for name in ("margin_s", "lead_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and 0 <= v <= 5):
                raise ValueError(f"{name} must be in [0, 5] seconds, got {v}")
        if not 0 <= self.video_crf <= 51:
            raise ValueError(f"video_crf must be in [0, 51], got {self.video_crf}")
        if self.video_long_side is not None and not 64 <= self.video_long_side <= 8192:
            raise ValueError(f"video_long_side must be in [64, 8192] pixels, got {self.video_long_side}")
        if not 1 <= self.video_queue_frames <= 600:
            raise ValueError(f"video_queue_frames must be in [1, 600], got {self.video_queue_frames}")
        if not 0 <= self.video_threads <= 16:
            raise ValueError(f"video_threads must be in [0, 16] (0: the encoder's), got {self.video_threads}")
        if not 1 <= self.video_stop_timeout_s <= 120:
            raise ValueError(f"video_stop_timeout_s must be in [1, 120], got {self.video_stop_timeout_s}")
        if not 1 <= self.max_duration_s <= 86400:
            raise ValueError(f"max_duration_s must be in [1, 86400], got {self.max_duration_s}")
