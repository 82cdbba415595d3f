"""gaitkit's example walking trials (JSON of per-frame landmark positions) to COCO-17.

Format (``gaitkit/data/example_*.json``): ``{"fps", "n_frames", "source", "doi",
"angle_frames": [{"landmark_positions": {name: [x, y, z] (mm)}, "is_valid"}, ...]}``. The
files do not share one lab frame: the vertical axis is named per clip in annotations.toml
(``up_axis`` y or z), and each was checked to be right-handed (the right hip lies to the
right of the walking direction, the toes ahead of the heels). A landmark at exactly (0, 0, 0)
is absent (NaN), as is every landmark of a frame with ``is_valid`` false.

Joint mapping (landmark -> COCO keypoint): ``left/right_hip`` -> hips (the files' hip
landmarks: joint centres in some files, pelvis markers 0.37 m apart in others; COCO's hip
keypoint lies between the two), ``left/right_knee`` -> knees, ``left/right_ankle`` -> ankles,
``left/right_shoulder`` -> shoulders. Elbows, wrists and the face are not in the files (NaN).
Foot points for the floor: ``left/right_heel``, ``left/right_toe`` and the ankles.
"""

from __future__ import annotations

import json

import numpy as np

from pipeline.errors import InputError
from pipeline.mocap.kinematics import F64
from pipeline.skeleton import NUM_JOINTS, J

# File axes -> CAVE axes (rows: CAVE x, y, z), proper rotations.
UP_AXES: dict[str, F64] = {
    "z": np.eye(3),
    "y": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
}
JOINTS = {
    "l_hip": "left_hip", "r_hip": "right_hip", "l_knee": "left_knee", "r_knee": "right_knee",
    "l_ankle": "left_ankle", "r_ankle": "right_ankle", "l_shoulder": "left_shoulder",
    "r_shoulder": "right_shoulder",
}  # fmt: skip
FEET = ("left_heel", "right_heel", "left_toe", "right_toe")


def read_landmarks(text: str, up_axis: str, name: str = "landmarks") -> tuple[F64, F64, F64, float]:
    """(joints (T, 17, 3), foot points (T, 6, 3), pelvis (T, 3), fps) in metres, CAVE axes."""
    if up_axis not in UP_AXES:
        raise InputError(f"{name}: up_axis must be one of {sorted(UP_AXES)}, got {up_axis!r}")
    try:
        data = json.loads(text)
        frames = data["angle_frames"]
        fps = float(data["fps"])
    except (ValueError, KeyError, TypeError) as exc:
        raise InputError(f"{name}: not a gaitkit landmark file ({exc})") from exc
    if len(frames) < 2 or not fps > 0:
        raise InputError(f"{name}: needs at least 2 frames and a positive fps")
    names = set(JOINTS.values()) | set(FEET)
    pos = {n: np.full((len(frames), 3), np.nan) for n in names}
    for t, f in enumerate(frames):
        lm = f.get("landmark_positions") or {}
        if not f.get("is_valid", True):
            continue
        for n in names:
            v = lm.get(n)
            if v is not None and len(v) == 3 and any(float(c) != 0.0 for c in v):
                pos[n][t] = v
    rot = UP_AXES[up_axis]
    pos = {n: (p / 1000.0) @ rot.T for n, p in pos.items()}
    out = np.full((len(frames), NUM_JOINTS, 3), np.nan)
    for coco, src in JOINTS.items():
        out[:, J[coco]] = pos[src]
    if np.isnan(out[:, [J["l_ankle"], J["r_ankle"]]]).all():
        raise InputError(f"{name}: no ankle landmarks")
    feet = np.stack([pos[n] for n in FEET] + [out[:, J["l_ankle"]], out[:, J["r_ankle"]]], axis=1)
    hips = out[:, [J["l_hip"], J["r_hip"]]]
    pelvis = np.where(np.isnan(hips).any(axis=(1, 2))[:, None], np.nan, hips.mean(axis=1))
    return out, feet, pelvis, fps
