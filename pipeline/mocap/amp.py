"""Isaac Lab's AMP humanoid motions (NPZ of per-frame body positions and rotations) to COCO-17.

Format (``isaaclab_tasks/contrib/humanoid_amp/motions/humanoid_*.npz`` of the isaaclab wheel,
described in the README beside them): ``fps`` (), ``body_names`` (B,), ``body_positions``
(N, B, 3) metres and ``body_rotations`` (N, B, 4) world quaternions (w, x, y, z), in a
+Z-up world. The model is the DeepMimic humanoid (the one pybullet's clips use, at pybullet's
0.25 scale: its body offsets, e.g. neck 0.223894 m above the chest, hips 0.084887 m beside the
root, match :mod:`pipeline.mocap.deepmimic`'s to 1e-6); a body's frame is the joint it hangs
from, +X forward, +Y left, +Z up in the rest pose. The world axes are kept as they are (a
right-handed, +Z-up frame, so left stays left; the walking direction is irrelevant here).

Joint mapping (body origin -> COCO keypoint, no offset): ``left/right_upper_arm`` ->
shoulders, ``left/right_lower_arm`` -> elbows, ``left/right_hand`` -> wrists,
``left/right_thigh`` -> hips, ``left/right_shin`` -> knees, ``left/right_foot`` -> ankles.
The face is placed on the head sphere by the offsets of :mod:`pipeline.mocap.deepmimic`
(the ``head`` body's frame is the neck joint's), turned into this model's axes. Foot points
for the floor: the 4 sole corners of each foot box (DeepMimic's foot box, below).

The files' floor is not level in time: in ``humanoid_walk.npz`` the stance feet rise ~5 cm over
2.6 s (pelvis too), a retargeting artefact. :func:`level_floor` removes a linear trend of the
floor (fitted to the 1 s windowed minima of the lowest sole point) before floor placement.
"""

from __future__ import annotations

import io
import zipfile

import numpy as np

from pipeline.errors import InputError
from pipeline.mocap.deepmimic import FACE_IN_NECK_FRAME, HEAD_ABOVE_NECK_M
from pipeline.mocap.kinematics import F64, quat_to_matrix
from pipeline.skeleton import NUM_JOINTS, J

# DeepMimic model axes (+X forward, +Y up, +Z right) -> this model's (+X forward, +Y left, +Z up)
DEEPMIMIC_TO_AMP: F64 = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
JOINTS = {
    "l_shoulder": "left_upper_arm", "r_shoulder": "right_upper_arm",
    "l_elbow": "left_lower_arm", "r_elbow": "right_lower_arm",
    "l_wrist": "left_hand", "r_wrist": "right_hand", "l_hip": "left_thigh", "r_hip": "right_thigh",
    "l_knee": "left_shin", "r_knee": "right_shin", "l_ankle": "left_foot", "r_ankle": "right_foot",
}  # fmt: skip
# Sole corners in a foot body's frame (m): DeepMimic's foot box (pybullet's humanoid.urdf x 0.25),
# 0.177 m long from 0.0435 m behind the ankle, 0.09 m wide, its bottom 0.05 m below the ankle.
SOLE_CORNERS: F64 = np.array(
    [[-0.0435, 0.045, -0.05], [-0.0435, -0.045, -0.05], [0.1335, 0.045, -0.05], [0.1335, -0.045, -0.05]]
)
KEYS = ("fps", "body_names", "body_positions", "body_rotations")
FLOOR_WINDOW_S = 1.0


def read_amp_motion(data: bytes, name: str = "motion") -> tuple[F64, F64, F64, float]:
    """(joints (T, 17, 3), foot points (T, 8, 3), pelvis (T, 3), fps) in metres, +Z up."""
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            fps = float(npz["fps"])
            names = [str(n) for n in npz["body_names"]]
            pos = np.asarray(npz["body_positions"], dtype=np.float64)
            quat = np.asarray(npz["body_rotations"], dtype=np.float64)
    except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:
        raise InputError(f"{name}: not an AMP motion NPZ with {list(KEYS)} ({exc})") from exc
    needed = {"pelvis", "head", *JOINTS.values()}
    if missing := sorted(needed - set(names)):
        raise InputError(f"{name}: lacks the bodies {missing}")
    if pos.ndim != 3 or pos.shape[1:] != (len(names), 3) or quat.shape != (*pos.shape[:2], 4):
        raise InputError(
            f"{name}: expected body_positions (N, {len(names)}, 3) and body_rotations (N, {len(names)}, 4), "
            f"got {pos.shape} and {quat.shape}"
        )
    if len(pos) < 2 or not fps > 0 or not (np.isfinite(pos).all() and np.isfinite(quat).all()):
        raise InputError(f"{name}: needs at least 2 finite frames and a positive fps, got {len(pos)}, {fps}")
    body = {n: i for i, n in enumerate(names)}
    out = np.full((len(pos), NUM_JOINTS, 3), np.nan)
    for coco, src in JOINTS.items():
        out[:, J[coco]] = pos[:, body[src]]
    neck_r = quat_to_matrix(quat[:, body["head"]])
    head = pos[:, body["head"]] + neck_r @ np.array([0.0, 0.0, HEAD_ABOVE_NECK_M])
    for coco, offset in FACE_IN_NECK_FRAME.items():
        out[:, J[coco]] = head + neck_r @ (DEEPMIMIC_TO_AMP @ np.asarray(offset))
    feet = []
    for foot in ("left_foot", "right_foot"):
        r = quat_to_matrix(quat[:, body[foot]])
        feet.append(pos[:, body[foot], None, :] + np.einsum("tij,kj->tki", r, SOLE_CORNERS))
    return out, np.concatenate(feet, axis=1), pos[:, body["pelvis"]].copy(), fps


def level_floor(joints: F64, feet: F64, pelvis: F64, fps: float) -> tuple[F64, F64, F64]:
    """The clip with a linear drift of its floor height removed (z only): the line fitted to the
    lowest foot point's minima over :data:`FLOOR_WINDOW_S` windows (each at its own time)."""
    lowest = np.nanmin(feet[..., 2], axis=1)
    half = max(1, round(FLOOR_WINDOW_S * fps / 2))
    at = np.unique([max(0, t - half) + int(np.nanargmin(lowest[max(0, t - half) : t + half + 1]))
                    for t in range(len(lowest))])  # fmt: skip
    t_s = np.arange(len(lowest)) / fps
    slope = np.polyfit(t_s[at], lowest[at], 1)[0] if len(at) > 1 else 0.0
    drift = np.outer(slope * t_s, [0.0, 0.0, 1.0])  # (T, 3)

    def minus(a: F64) -> F64:
        return np.asarray(a - drift.reshape((len(a),) + (1,) * (a.ndim - 2) + (3,)), dtype=np.float64)

    return minus(joints), minus(feet), minus(pelvis)
