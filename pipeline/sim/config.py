"""The simulator's frozen config: the settings' ``[sim]`` section (:class:`SimConfig`), the camera
faults it simulates (:class:`FaultConfig`) and the camera models it can place
(:data:`PRESETS`). No heavy imports here (the virtual cameras' ``pipeline.camera`` loads cv2): the
world itself is :mod:`pipeline.sim.world`, the cameras :mod:`pipeline.sim.scene` and
:mod:`pipeline.sim.views`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError

F64 = NDArray[np.float64]

# home spots of the stepping people after the navigator (issue 20: several navigators)
STEPPER_HOMES_M: tuple[tuple[float, float], ...] = ((0.9, 0.9), (-0.9, -0.9), (0.9, -0.9))


@dataclass(frozen=True, slots=True)
class CameraPreset:
    """Intrinsics of a camera model: image (width, height), focal length, distortion."""

    name: str
    image_size: tuple[int, int]
    focal_px: float
    dist: tuple[float, float, float, float, float]

    def K(self) -> F64:
        w, h = self.image_size
        cx, cy = (w - 1) / 2.0, (h - 1) / 2.0  # as pipeline.camera.intrinsics builds it (no cv2 here)
        return np.array([[self.focal_px, 0.0, cx], [0.0, self.focal_px, cy], [0.0, 0.0, 1.0]])


PRESETS: dict[str, CameraPreset] = {
    "kinect_color": CameraPreset("kinect_color", (1920, 1080), 1060.0, (0.04, -0.06, 0.0005, -0.0003, 0.02)),
    "depth": CameraPreset("depth", (640, 576), 505.0, (0.06, -0.12, 0.0002, 0.0001, 0.04)),
}


@dataclass(frozen=True, slots=True)
class FaultConfig:
    """What goes wrong in a simulated camera.

    pixel_noise_px: keypoint noise sigma for a person 600 px tall (scales with size and joint).
    score_visible: (mean, sd) of a visible keypoint's confidence.
    score_hidden: (min, max) confidence of a self-occluded / occluded keypoint (uniform).
    hidden_noise_scale: extra noise factor for hidden keypoints (the detector guesses).
    joint_drop_rate: probability that a visible keypoint is missed anyway.
    person_miss_rate: probability that a visible person is not detected in a view.
    false_detection_rate: expected ghost detections per view and frame.
    timestamp_jitter_s: sd of the camera timestamp around the true frame time.
    min_visible_keypoints: fewer visible keypoints than this = not detected.
    min_box_height_px: persons smaller than this are not detected.
    occlusion: model occlusion by bodies (False: only the image border hides joints).
    """

    pixel_noise_px: float = 2.5
    score_visible: tuple[float, float] = (0.9, 0.05)
    score_hidden: tuple[float, float] = (0.05, 0.45)
    hidden_noise_scale: float = 3.0
    joint_drop_rate: float = 0.01
    person_miss_rate: float = 0.02
    false_detection_rate: float = 0.01
    timestamp_jitter_s: float = 0.002
    min_visible_keypoints: int = 4
    min_box_height_px: float = 24.0
    occlusion: bool = True

    def __post_init__(self) -> None:
        for name in (
            "pixel_noise_px",
            "hidden_noise_scale",
            "false_detection_rate",
            "timestamp_jitter_s",
            "min_box_height_px",
        ):
            v = float(getattr(self, name))
            if not np.isfinite(v) or v < 0:
                raise InputError(f"faults: {name} must be >= 0, got {v}")
            object.__setattr__(self, name, v)
        for name in ("joint_drop_rate", "person_miss_rate"):
            v = float(getattr(self, name))
            if not 0.0 <= v <= 1.0:
                raise InputError(f"faults: {name} must be in [0, 1], got {v}")
            object.__setattr__(self, name, v)
        m, sd = (float(x) for x in self.score_visible)
        lo, hi = (float(x) for x in self.score_hidden)
        if not (0 < m <= 1 and sd >= 0 and 0 <= lo <= hi <= 1):
            raise InputError(
                f"faults: scores must lie in [0, 1], got visible {self.score_visible}, "
                f"hidden {self.score_hidden}"
            )
        object.__setattr__(self, "score_visible", (m, sd))
        object.__setattr__(self, "score_hidden", (lo, hi))
        if int(self.min_visible_keypoints) < 1:
            raise InputError(f"faults: min_visible_keypoints must be >= 1, got {self.min_visible_keypoints}")

    @classmethod
    def perfect(cls) -> FaultConfig:
        """No noise, misses, ghosts or jitter: exact projections (visible joints score 1)."""
        return cls(
            pixel_noise_px=0.0,
            score_visible=(1.0, 0.0),
            hidden_noise_scale=0.0,
            joint_drop_rate=0.0,
            person_miss_rate=0.0,
            false_detection_rate=0.0,
            timestamp_jitter_s=0.0,
        )

    def replace(self, **changes: object) -> FaultConfig:
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        values.update(changes)
        return FaultConfig(**values)  # type: ignore[arg-type]


@dataclass(frozen=True, slots=True)
class SimConfig:
    """Settings of a simulated world.

    fps: frames per second. bystanders: people besides the navigator. seed: everything random.
    camera_preset / camera_count: the virtual cameras (see :mod:`pipeline.sim.scene`).
    chunk_s: length of each random routine generated on the fly.
    faults: what goes wrong in the cameras.
    navigator_height_m: None = a random height in 1.40-2.05 m.
    repeat_script: after the navigator's script ends, play it again (else random routines).
    observe: run the virtual cameras (False: ground truth only, ``views`` stay empty; faster).
    script: the navigator's routine file (JSON/TOML, :func:`pipeline.sim.script.load_script`);
        None = random routines.
    people: people who step (the navigator and ``people - 1`` more, each with random routines
        round a home spot of their own, :data:`STEPPER_HOMES_M`; issue 20), besides the bystanders.
    """

    fps: float = 30.0
    bystanders: int = 1
    seed: int = 0
    camera_preset: str = "kinect_color"
    camera_count: int = 4
    chunk_s: float = 60.0
    faults: FaultConfig = field(default_factory=FaultConfig)
    navigator_height_m: float | None = None
    repeat_script: bool = False
    observe: bool = True
    script: Path | None = None
    people: int = 1

    def __post_init__(self) -> None:
        if not 1 <= int(self.people) <= 1 + len(STEPPER_HOMES_M):
            raise InputError(f"sim people must be 1..{1 + len(STEPPER_HOMES_M)}, got {self.people}")
        if not math.isfinite(self.fps) or not 1.0 <= self.fps <= 240.0:
            raise InputError(f"sim fps must be in [1, 240], got {self.fps}")
        if not 0 <= int(self.bystanders) <= 8:
            raise InputError(f"sim bystanders must be 0..8, got {self.bystanders}")
        if self.camera_preset not in PRESETS:
            raise InputError(
                f"unknown camera preset {self.camera_preset!r}; presets are {', '.join(PRESETS)}"
            )
        if not 1 <= int(self.camera_count) <= 8:
            raise InputError(f"sim camera_count must be 1..8, got {self.camera_count}")
        if not 2.0 <= self.chunk_s <= 3600.0:
            raise InputError(f"sim chunk_s must be in [2, 3600], got {self.chunk_s}")
        if self.navigator_height_m is not None and not 1.0 <= self.navigator_height_m <= 2.3:
            raise InputError(f"navigator_height_m must be in [1.0, 2.3], got {self.navigator_height_m}")
