"""The pose stage's one frozen config: the pose model and its ROI crops (the settings' ``[pose]``),
and how ``cavewalk tune`` measures them (``[tune]``, :class:`TuneConfig`).

Every field is a setting (``[pose]`` in ``cavewalk.toml``, ``CAVEWALK_POSE__<FIELD>``);
its default and its check live here and nowhere else.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from pipeline.pose.model_files import Precision, crop_model_path, pose_model_file, usable_model_path

STRIDE = 32  # the network's largest stride: every input side is a multiple of it
MIN_CROP_SIDE = 128  # the shortest crop network height, px
Provider = Literal["cpu", "cuda", "tensorrt", "openvino"]
PROVIDERS: dict[str, str] = {"cpu": "CPUExecutionProvider", "cuda": "CUDAExecutionProvider",
                             "tensorrt": "TensorrtExecutionProvider", "openvino": "OpenVINOExecutionProvider"}


@dataclass(frozen=True, slots=True)
class PoseConfig:
    """How the pose model runs, on whole views and on crops around tracked people.

    model: a YOLO-pose ONNX file with output (B, 56, N); None = the model ``cavewalk models
        prepare`` made in the models folder, of ``precision``.
    precision: ``fp32`` or its ``int8`` copy (6-14 % faster, same tracks; see bench_detect).
    input_long_side: long side of the whole-view network input, px (multiple of 32); the short
        side follows the images' aspect (1088x1920 portrait views run at 384x640, not padded).
    score_threshold: minimum person score. nms_iou: IoU above which NMS drops a box.
    keypoint_threshold: keypoints scored lower are drawn as unknown.
    providers: ``cpu``, ``cuda``, ``tensorrt``, ``openvino``, in order of preference (those not
        installed are skipped; the CPU is always the last resort).
    threads: onnxruntime intra-op threads per model call (0 = its choice; 1 when parallel > 1).
    parallel: model calls of a frame run side by side on this many threads (0 = one per core, up to 4).
    crop_model: ROI crops run on the crop model beside the model file (the head without its
        stride-8 level, a third faster in int8; see :mod:`pipeline.pose.model_files`).
    max_people: at most this many people per image.
    spinning: onnxruntime's idle threads spin-wait between runs (faster alone on a machine, but
        it takes CPU from video decoders and other processes on few cores).

    ROI mode (:mod:`pipeline.pose.roi`): roi: run tracked views on crops around their tracks.
    roi_long_side: the tallest crop network, px (multiple of 32). roi_min_side: the shortest
    (multiple of 32; None = ``min(128, roi_long_side)``). roi_margin: crop margin on each side,
    fraction of the expected box's larger side. roi_full_every: each view is looked at whole (for
    newcomers) at least this often, frames. roi_max_crops: more crops than this in a frame ->
    whole views instead.
    roi_min_aspect / roi_max_aspect: bounds of a crop's aspect w / h (a person with arms out widens
    the crop). roi_merge_growth: two people of a view share one crop when their union is at most
    this many times the larger one's area.

    Staggered views (:mod:`pipeline.pose.stagger`): views_per_frame: the model looks at most at
    this many views per frame, the others carry their tracked people along the tracker's motion
    (0 = adaptive: every view while the frames keep coming one after the other, one view less at
    a time while frames are being skipped, down to min_views_per_frame: on the demo, two of four
    views per frame keep every id and the 3D joints within 27 mm (median) of detecting all four;
    one of four loses the bystander in 3D half the time, see scripts/eval_stagger.py). carry_decay /
    carry_keypoint_decay: a carried person's box score / keypoint scores are multiplied by this for
    every frame without a detection (the triangulation weighs keypoints by their scores: the
    fresh views count most).
    """

    model: Path | None = None
    precision: Precision = "int8"
    input_long_side: int = 640
    score_threshold: float = 0.35
    nms_iou: float = 0.6
    keypoint_threshold: float = 0.3
    providers: tuple[Provider, ...] = ("cpu",)
    threads: int = 0
    parallel: int = 0
    crop_model: bool = True
    max_people: int = 16
    spinning: bool = False
    roi: bool = True
    roi_long_side: int = 320
    roi_min_side: int | None = None
    roi_margin: float = 0.15
    roi_full_every: int = 30
    roi_max_crops: int = 12
    roi_min_aspect: float = 0.4
    roi_max_aspect: float = 1.0
    roi_merge_growth: float = 1.1
    views_per_frame: int = 0
    min_views_per_frame: int = 2
    carry_decay: float = 0.9
    carry_keypoint_decay: float = 0.6

    def __post_init__(self) -> None:
        for name in ("input_long_side", "roi_long_side", "roi_min_side"):
            value = getattr(self, name)
            if value is not None and (value < STRIDE or value % STRIDE):
                raise ValueError(f"{name} must be a positive multiple of {STRIDE}, got {value}")
        if self.roi_min_side is not None and self.roi_min_side > self.roi_long_side:
            raise ValueError(f"roi_min_side {self.roi_min_side} must not exceed roi_long_side "
                             f"{self.roi_long_side}")
        for name in ("score_threshold", "nms_iou", "keypoint_threshold"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {value}")
        if self.precision not in ("fp32", "int8"):
            raise ValueError(f"precision must be 'fp32' or 'int8', got {self.precision!r}")
        unknown = [p for p in self.providers if p not in PROVIDERS]
        if unknown or not self.providers:
            raise ValueError(f"providers must be a non-empty subset of {sorted(PROVIDERS)}, "
                             f"got {self.providers}")
        if self.threads < 0 or self.parallel < 0 or self.max_people < 1:
            raise ValueError(f"threads and parallel must be >= 0 and max_people >= 1, got {self.threads}, "
                             f"{self.parallel}, {self.max_people}")
        if not 0.0 <= self.roi_margin <= 2.0:
            raise ValueError(f"roi_margin must be in [0, 2], got {self.roi_margin}")
        if self.roi_full_every < 1 or self.roi_max_crops < 1:
            raise ValueError(f"roi_full_every and roi_max_crops must be >= 1, got {self.roi_full_every}, "
                             f"{self.roi_max_crops}")
        if self.roi_merge_growth < 1:
            raise ValueError(f"roi_merge_growth must be >= 1, got {self.roi_merge_growth}")
        if self.views_per_frame < 0 or self.min_views_per_frame < 1:
            raise ValueError(f"views_per_frame must be >= 0 and min_views_per_frame >= 1, got "
                             f"{self.views_per_frame}, {self.min_views_per_frame}")
        if not 0.0 < self.carry_decay <= 1.0 or not 0.0 < self.carry_keypoint_decay <= 1.0:
            raise ValueError(f"carry_decay and carry_keypoint_decay must be in (0, 1], got "
                             f"{self.carry_decay}, {self.carry_keypoint_decay}")
        if not 0 < self.roi_min_aspect <= self.roi_max_aspect:
            raise ValueError(f"need 0 < roi_min_aspect <= roi_max_aspect, got {self.roi_min_aspect}, "
                             f"{self.roi_max_aspect}")

    @property
    def crop_min_side(self) -> int:
        """The shortest crop network height, px."""
        return self.roi_min_side if self.roi_min_side is not None else min(MIN_CROP_SIDE, self.roi_long_side)

    @property
    def runs(self) -> int:
        """How many model calls run side by side (``parallel``, 0 resolved to the CPU count, up to 4)."""
        return self.parallel or min(os.cpu_count() or 1, 4)

    @property
    def intra_op_threads(self) -> int:
        """onnxruntime intra-op threads per call (0 = its choice)."""
        return self.threads or (1 if self.runs > 1 else 0)

    def model_file(self, models_dir: Path) -> Path:
        """The model file: ``model``, else the prepared model of ``precision`` in ``models_dir``
        (the float32 one when ``models prepare`` did not keep the int8 copy: it missed the check)."""
        if self.model is not None:
            return self.model
        return usable_model_path(pose_model_file(models_dir, self.precision))

    def crop_model_file(self, model_path: Path) -> Path | None:
        """The crop model beside ``model_path`` when ``crop_model`` is on and it exists, else None
        (crops then run on the model itself); a rejected int8 crop model gives its float32 one."""
        crop = usable_model_path(crop_model_path(Path(model_path)))
        return crop if self.crop_model and crop.is_file() else None


#: the keys of ``[pose]`` that ``cavewalk tune`` writes (and the settings take from its file)
TUNED_KEYS = ("precision", "crop_model", "roi_long_side", "threads", "parallel", "providers")
FINGERPRINT_KEYS = ("cpu_model", "logical_cores", "onnxruntime")


@dataclass(frozen=True, slots=True)
class TuneConfig:
    """The settings' ``[tune]`` section.

    on_first_start: ``cavewalk demo`` / ``serve`` run the tuning first when this machine has no
        result yet (and the pose model is prepared).
    crop_sides: the crop sizes measured (``pose.roi_long_side``, multiples of 32).
    repeats: timed rounds per variant (the median is kept; other processes share the CPU).
    lanes: the (threads, parallel) pairs measured; empty = 1 x 1, all cores x 1, 1 x up to 4.
    """

    on_first_start: bool = True
    crop_sides: tuple[int, ...] = (320, 256, 224, 192)
    repeats: int = 3
    lanes: tuple[tuple[int, int], ...] = ()

    def __post_init__(self) -> None:
        if not self.crop_sides or any(s < 32 or s % 32 for s in self.crop_sides):
            raise ValueError(f"crop_sides must be multiples of 32, got {self.crop_sides}")
        if self.repeats < 1:
            raise ValueError(f"repeats must be >= 1, got {self.repeats}")
        if any(t < 0 or p < 1 for t, p in self.lanes):
            raise ValueError(f"lanes must be (threads >= 0, parallel >= 1) pairs, got {self.lanes}")
