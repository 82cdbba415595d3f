"""The geometry of the head pose: a rigid face template fitted to the 3D face keypoints.

Head frame (the SPEC's axes for a person): x to the person's right, y forward (where the face
points), z up; its origin between the ears. The template holds the five COCO face keypoints
(nose, eyes, ears) in that frame for an average adult: ears 0.15 m apart (bitragion breadth),
eyes 0.066 m apart (interpupillary distance) and 0.088 m ahead of the ear line, the nose tip
0.105 m ahead and 0.035 m below it. A weighted Kabsch fit of the template to the face keypoints
that were triangulated gives the rotation from any three of them (people turn their heads, so
an ear or an eye is often hidden). With fewer, the shoulder line gives the yaw (the head faces
where the trunk faces) and the face points the position.

The reported position is the point between the eyes (the viewpoint a CAVE renders from), the
forward and up vectors are the frame's y and z axes in the CAVE frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.skeleton import J

F64 = NDArray[np.float64]
B = NDArray[np.bool_]

FACE_JOINTS: tuple[int, ...] = (J["nose"], J["l_eye"], J["r_eye"], J["l_ear"], J["r_ear"])
#: (5, 3) the face keypoints of FACE_JOINTS in the head frame, metres.
FACE_TEMPLATE_M: F64 = np.array(
    [
        [0.0, 0.105, -0.035],
        [-0.033, 0.088, 0.0],
        [0.033, 0.088, 0.0],
        [-0.075, 0.0, 0.0],
        [0.075, 0.0, 0.0],
    ]
)
#: the point between the eyes in the head frame (the reported position).
EYE_CENTRE_M: F64 = np.array([0.0, 0.088, 0.0])
_WORLD_UP = np.array([0.0, 0.0, 1.0])
METHODS = ("face", "partial", "shoulders")
_MIN_SPREAD = 0.05  # a fit whose second singular value is below this fraction of the first is degenerate


@dataclass(frozen=True, slots=True)
class HeadFrame:
    """One head pose in the CAVE frame.

    position_m: (3,) the point between the eyes, metres.
    rotation: (3, 3) head-to-CAVE rotation; columns = right, forward, up (unit vectors).
    method: ``face`` (template fitted to >= 3 face keypoints), ``partial`` (fewer: the track's
        predicted rotation, turned to fit them) or ``shoulders`` (fewer and no track: level,
        yaw from the shoulder line); the position always from the face keypoints seen.
    residual_m: RMS distance of the fitted template to the face keypoints used.
    scale: the template's size in the fit (1 = the average adult's).
    """

    position_m: F64
    rotation: F64
    method: str = "face"
    residual_m: float = 0.0
    scale: float = 1.0

    def __post_init__(self) -> None:
        p = np.asarray(self.position_m, dtype=np.float64)
        r = np.asarray(self.rotation, dtype=np.float64)
        if p.shape != (3,) or r.shape != (3, 3):
            raise ValueError(f"position_m must be (3,) and rotation (3, 3), got {p.shape}, {r.shape}")
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        object.__setattr__(self, "position_m", p)
        object.__setattr__(self, "rotation", r)

    @property
    def forward(self) -> F64:
        f: F64 = self.rotation[:, 1]
        return f

    @property
    def up(self) -> F64:
        u: F64 = self.rotation[:, 2]
        return u


def _rotation_from(h: F64) -> tuple[F64, NDArray[np.float64], float]:
    """The rotation maximising trace(R H') for a cross-covariance ``h`` (Kabsch), its singular
    values and the determinant sign used."""
    u, sv, vt = np.linalg.svd(h)
    d = 1.0 if np.linalg.det(vt.T @ u.T) >= 0 else -1.0
    rot: F64 = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return rot, sv, d


def kabsch(
    template: F64, points: F64, weights: F64, with_scale: bool = False
) -> tuple[F64, F64, float, float]:
    """Weighted rigid (``with_scale``: similarity, Umeyama 1991) fit ``points ~ s R @ template + t``:
    (R (3, 3), t (3,), s, the spread ratio s2/s1 of the cross-covariance: 0 for a degenerate,
    collinear set)."""
    w = weights / weights.sum()
    tc, pc = w @ template, w @ points
    h = (template - tc).T @ ((points - pc) * w[:, None])
    rot, sv, d = _rotation_from(h)
    scale = 1.0
    if with_scale:
        var = float(w @ np.sum((template - tc) ** 2, axis=1))
        scale = float((sv[0] + sv[1] + d * sv[2]) / var) if var > 0 else 1.0
    t: F64 = pc - scale * rot @ tc
    return rot, t, scale, float(sv[1] / sv[0]) if sv[0] > 0 else 0.0


def frame_from_right(right: F64) -> F64 | None:
    """A level head frame (up = +Z) whose right axis is ``right`` projected on the floor."""
    r = np.array([right[0], right[1], 0.0])
    n = float(np.linalg.norm(r))
    if not math.isfinite(n) or n < 1e-6:
        return None
    r /= n
    fwd = np.cross(_WORLD_UP, r)
    return np.stack([r, fwd, _WORLD_UP], axis=1)


#: weights of the priors against one observed face keypoint: the track's last rotation, and the
#: shoulder line (level, facing where the trunk faces).
PRIOR_WEIGHT = 0.05
SHOULDER_WEIGHT = 0.01
_TEMPLATE_SCATTER = FACE_TEMPLATE_M - FACE_TEMPLATE_M.mean(axis=0)


def _prior_h(rotation: F64, weight: float) -> F64:
    """The cross-covariance the whole template would add if it were seen at ``rotation``."""
    h: F64 = weight * _TEMPLATE_SCATTER.T @ (_TEMPLATE_SCATTER @ rotation.T)
    return h


def head_pose_from_joints(
    joints_m: F64,
    valid: B | None = None,
    min_face_joints: int = 3,
    scale: float | None = 1.0,
    prior_rotation: F64 | None = None,
) -> HeadFrame | None:
    """The head pose of one (17, 3) skeleton (NaN or ``valid`` False where unknown), or None.

    With ``min_face_joints`` or more face keypoints not on one line, the rotation is the
    template's Kabsch fit to them (``face``). With fewer (a turned head, a hidden face) the fit is
    regularised by two priors, as if the whole template had also been seen with a small weight:
    at ``prior_rotation`` (the track's last rotation) and level along the shoulder line; so two
    keypoints' line still turns the head and the priors keep the rest (``partial`` with a track,
    ``shoulders`` without). The position comes from the face
    keypoints seen. None without any face keypoint, or with fewer than ``min_face_joints`` and
    neither a prior nor the shoulders.

    scale: the template's size for this person (1 = the average adult); None = fitted too (a
    similarity fit without priors: exact on noise-free joints, noisy on measured ones).
    """
    joints = np.asarray(joints_m, dtype=np.float64)
    k = 1.0 if scale is None else float(scale)
    template_m, eye = FACE_TEMPLATE_M * k, EYE_CENTRE_M * k
    ok = np.all(np.isfinite(joints), axis=1)
    if valid is not None:
        ok &= np.asarray(valid, dtype=bool)
    face = np.array(FACE_JOINTS)
    seen = ok[face]
    pts, tpl = joints[face][seen], template_m[seen]
    if len(pts) == 0:
        return None
    if scale is None:
        if len(pts) < min_face_joints:
            return None
        rot, t, s, spread = kabsch(tpl, pts, np.ones(len(pts)), with_scale=True)
        if spread < _MIN_SPREAD:
            return None
        res = float(np.sqrt(np.mean(np.sum((pts - (s * tpl @ rot.T + t)) ** 2, axis=1))))
        return HeadFrame(s * rot @ eye + t, rot, "face", res, s)
    tc, pc = tpl.mean(axis=0), pts.mean(axis=0)
    h_obs = (tpl - tc).T @ (pts - pc) / k**2  # per keypoint, in the unit template's units
    spread = 0.0
    if len(pts) >= 2:
        sv = np.linalg.svd(h_obs, compute_uv=False)
        spread = float(sv[1] / sv[0]) if sv[0] > 0 else 0.0
    strong = len(pts) >= min_face_joints and spread >= _MIN_SPREAD
    h = h_obs.copy()
    if not strong:
        ls, rs = J["l_shoulder"], J["r_shoulder"]
        level = frame_from_right(joints[rs] - joints[ls]) if ok[ls] and ok[rs] else None
        if prior_rotation is None and level is None:
            return None
        if prior_rotation is not None:
            h += _prior_h(np.asarray(prior_rotation, dtype=np.float64), PRIOR_WEIGHT)
        if level is not None:
            h += _prior_h(level, SHOULDER_WEIGHT)
    rot, _, _ = _rotation_from(h)
    t = pc - rot @ tc
    res = float(np.sqrt(np.mean(np.sum((pts - (tpl @ rot.T + t)) ** 2, axis=1))))
    method = "face" if strong else ("partial" if prior_rotation is not None else "shoulders")
    return HeadFrame(rot @ eye + t, rot, method, res, k)


def angle_deg(rot_a: F64, rot_b: F64) -> float:
    """The angle of the rotation between two head frames, degrees (0-180)."""
    chord = float(np.linalg.norm(rot_a - rot_b)) / (2.0 * math.sqrt(2.0))  # = sin(angle / 2)
    return math.degrees(2.0 * math.asin(min(1.0, chord)))


def direction_angle_deg(a: F64, b: F64) -> float:
    """The angle between two direction vectors, degrees."""
    c = float(a @ b) / max(float(np.linalg.norm(a) * np.linalg.norm(b)), 1e-12)
    return math.degrees(math.acos(min(1.0, max(-1.0, c))))
