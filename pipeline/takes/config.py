"""The settings' ``[takes]`` section, and the options of a fine-tuning run on takes (``cavewalk train``;
the training itself is :mod:`pipeline.takes.finetune`)."""

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


@dataclass(frozen=True, slots=True)
class FinetuneConfig:
    """Settings of one fine-tuning run (the ``cavewalk train`` options).

    epochs x windows_per_epoch windows (batch_size each step) at learning rate lr (AdamW, cosine);
    sim_routines of sim_duration_s simulated routines (stepping and still, in turn) join the takes;
    loso: leave-one-participant-out figures (one more fine-tune per participant, when >= 2);
    heldout_routines: simulated test routines (seed 7919) scored with the base and the new model.
    """

    epochs: int = 2
    windows_per_epoch: int = 4096
    batch_size: int = 128
    lr: float = 5e-4
    weight_decay: float = 1e-3
    label_smoothing: float = 0.05
    sim_routines: int = 8
    sim_duration_s: float = 20.0
    seed: int = 0
    threads: int = 1
    loso: bool = True
    heldout_routines: int = 4

    def __post_init__(self) -> None:
        if self.epochs < 1 or self.windows_per_epoch < self.batch_size or self.batch_size < 1:
            raise ValueError(
                f"epochs >= 1 and windows_per_epoch >= batch_size >= 1, got {self.epochs}, "
                f"{self.windows_per_epoch}, {self.batch_size}"
            )
        if not 0 < self.lr < 1 or self.sim_routines < 0 or self.heldout_routines < 0:
            raise ValueError("lr must be in (0, 1); sim_routines and heldout_routines >= 0")
        if self.sim_duration_s < 4:
            raise ValueError(f"sim_duration_s must be >= 4 s, got {self.sim_duration_s}")
