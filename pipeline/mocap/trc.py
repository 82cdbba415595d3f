"""OpenSim TRC marker files (text) and their skin-marker sets to COCO-17.

Format (OpenSim's "PathFileType 4 (X/Y/Z)"): line 1 names the file; line 2 the header keys
(``DataRate CameraRate NumFrames NumMarkers Units ...``) and line 3 their values, tab-separated;
line 4 ``Frame# Time`` then one name per marker (each followed by two empty columns); line 5
``X1 Y1 Z1 X2 ...``; then one line per frame: frame number, time, x y z per marker. An empty
field is a missing marker (NaN). The markers come back as a :class:`C3DPoints` (the same
container as the C3D reader's: labels, rate, units, points in the file's units).

Joint mapping (:func:`trc_to_coco`, the marker names of opensim-core's test trials; the lab frame
is +Y up, turned to +Z up by the proper rotation (x, y, z) -> (x, -z, y), so left stays left):
    hips    <- ``R_HJC`` / ``L_HJC`` when the file has them, else Bell et al. (1982) from the
             pelvis markers: from each ASIS, 30 % of the inter-ASIS width down, 22 % back and
             14 % inwards, in the frame of the ASIS pair and the sacral marker (``V.Sacral`` or
             ``S2``, else the mean of ``R.PSIS``/``L.PSIS``)
    knees / ankles <- midpoint of the lateral and medial markers (``R.Knee.Lat`` + ``R.Knee.Med``,
             ``R.Ankle.Lat`` + ``R.Ankle.Med``); with a lateral marker only (``R.Knee``,
             ``R.Ankle``), that marker moved inwards along the hips' axis by 5 cm (knee) / 3.5 cm
             (ankle), half a typical joint width
    shoulders <- ``R/L.Acromium`` or ``R/L.Shoulder``; elbows <- ``R/L.Elbow``; wrists <- midpoint
             of ``R/L.Wrist.Med`` and ``R/L.Wrist.Lat``, or ``R/L.Wrist``
    face    <- ``R.Temple``, ``L.Temple``, ``Top.Head``: M the temples' midpoint, s (left) and
             u (up, M to Top.Head, made orthogonal to s), forward f = s x u; nose = M + 0.09 f
             - 0.03 u, eyes = M + 0.06 f +- 0.032 s, ears = each temple - 0.03 f - 0.02 u.
A joint whose markers are absent is NaN. Foot points for the floor: heel, toe, midfoot and
metatarsal markers and the ankles.
"""

from __future__ import annotations

import numpy as np

from pipeline.errors import InputError
from pipeline.mocap.c3d import C3DPoints
from pipeline.mocap.kinematics import F64, unit_across, unit_rows
from pipeline.mocap.markers import foot_points
from pipeline.skeleton import NUM_JOINTS, J

Y_UP_TO_Z_UP: F64 = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
JOINT_MARKERS: dict[str, tuple[tuple[str, ...], ...]] = {  # alternatives, the first the file has wins
    "r_knee": (("R.Knee.Lat", "R.Knee.Med"),), "l_knee": (("L.Knee.Lat", "L.Knee.Med"),),
    "r_ankle": (("R.Ankle.Lat", "R.Ankle.Med"),), "l_ankle": (("L.Ankle.Lat", "L.Ankle.Med"),),
    "r_shoulder": (("R.Acromium",), ("R.Shoulder",)), "l_shoulder": (("L.Acromium",), ("L.Shoulder",)),
    "r_elbow": (("R.Elbow",),), "l_elbow": (("L.Elbow",),),
    "r_wrist": (("R.Wrist.Med", "R.Wrist.Lat"), ("R.Wrist",)),
    "l_wrist": (("L.Wrist.Med", "L.Wrist.Lat"), ("L.Wrist",)),
}  # fmt: skip
# A lateral marker alone (no medial one): the joint centre is this far (m) inwards of it, along
# the hips' left-right axis (half a typical knee / ankle width).
LATERAL_ONLY: dict[str, tuple[str, float]] = {
    "r_knee": ("R.Knee", 0.05), "l_knee": ("L.Knee", 0.05),
    "r_ankle": ("R.Ankle", 0.035), "l_ankle": ("L.Ankle", 0.035),
}  # fmt: skip
FOOT_MARKERS = (
    "R.Heel", "L.Heel", "R.Toe.Tip", "L.Toe.Tip", "R.Midfoot.Lat", "L.Midfoot.Lat", "R.Toe.Lat",
    "L.Toe.Lat", "R.Toe.Med", "L.Toe.Med", "R.MT1", "L.MT1", "R.MT5", "L.MT5",
)  # fmt: skip
BELL = (0.30, 0.22, 0.14)  # down, back, inwards from the ASIS, x the inter-ASIS width


def read_trc(text: str, name: str = "trc") -> C3DPoints:
    """The marker trajectories of a TRC file's text (points in the file's units, NaN = missing)."""
    lines = text.splitlines()
    if len(lines) < 6 or not lines[0].startswith("PathFileType"):
        raise InputError(f"{name}: not a TRC file (no PathFileType header)")
    header = dict(zip(lines[1].split("\t"), lines[2].split("\t"), strict=False))
    header = {k.strip(): v.strip() for k, v in header.items()}
    try:
        rate = float(header["DataRate"])
        units = header["Units"]
    except (KeyError, ValueError) as exc:
        raise InputError(f"{name}: TRC header lacks a DataRate or Units ({exc})") from exc
    labels = tuple(s.strip() for s in lines[3].split("\t")[2:] if s.strip())
    if not labels or not rate > 0:
        raise InputError(f"{name}: TRC needs marker names and a positive DataRate, got {rate}")
    rows = []
    for n, line in enumerate(lines[5:], start=6):
        fields = line.split("\t")
        if not line.strip() or len(fields) < 2:
            continue
        try:
            vals = [float(v) if v.strip() else np.nan for v in fields[2 : 2 + 3 * len(labels)]]
        except ValueError as exc:
            raise InputError(f"{name}: line {n} has a field that is not a number ({exc})") from exc
        rows.append(vals + [np.nan] * (3 * len(labels) - len(vals)))
    if len(rows) < 2:
        raise InputError(f"{name}: TRC has fewer than 2 frames")
    points = np.asarray(rows, dtype=np.float64).reshape(len(rows), len(labels), 3)
    return C3DPoints(labels, rate, units, 1, points)


def _marker(pts: C3DPoints, xyz: F64, name: str) -> F64 | None:
    return xyz[:, pts.labels.index(name)] if name in pts.labels else None


def _bell_hips(pts: C3DPoints, xyz: F64) -> tuple[F64, F64] | None:
    """(right, left) hip joint centres from the pelvis markers (Bell et al. 1982), None if absent."""
    r_asis, l_asis = _marker(pts, xyz, "R.ASIS"), _marker(pts, xyz, "L.ASIS")
    sacral = _marker(pts, xyz, "V.Sacral")
    sacral = _marker(pts, xyz, "S2") if sacral is None else sacral
    psis = [m for m in (_marker(pts, xyz, "R.PSIS"), _marker(pts, xyz, "L.PSIS")) if m is not None]
    if sacral is None and len(psis) == 2:
        sacral = (psis[0] + psis[1]) / 2
    if r_asis is None or l_asis is None or sacral is None:
        return None
    width = np.linalg.norm(l_asis - r_asis, axis=-1, keepdims=True)
    s = unit_rows(l_asis - r_asis)  # left
    f = (r_asis + l_asis) / 2 - sacral
    f = unit_across(f, s)  # forward
    u = np.cross(f, s)  # up
    down, back, inwards = BELL
    off = -down * u - back * f
    return (r_asis + width * (off + inwards * s), l_asis + width * (off - inwards * s))


def trc_to_coco(pts: C3DPoints) -> tuple[F64, F64, F64]:
    """(joints (T, 17, 3), foot points (T, P, 3), pelvis (T, 3)) in metres, +Z up."""
    xyz = pts.metres() @ Y_UP_TO_Z_UP.T
    out = np.full((len(xyz), NUM_JOINTS, 3), np.nan)
    for joint, alternatives in JOINT_MARKERS.items():
        for names in alternatives:
            if all(n in pts.labels for n in names):
                out[:, J[joint]] = np.mean([xyz[:, pts.labels.index(n)] for n in names], axis=0)
                break
    r_hjc, l_hjc = _marker(pts, xyz, "R_HJC"), _marker(pts, xyz, "L_HJC")
    hips = (r_hjc, l_hjc) if r_hjc is not None and l_hjc is not None else _bell_hips(pts, xyz)
    if hips is not None:
        out[:, J["r_hip"]], out[:, J["l_hip"]] = hips
        left = unit_rows(hips[1] - hips[0])
        for joint, (name, inwards) in LATERAL_ONLY.items():
            lateral = _marker(pts, xyz, name)
            if lateral is not None and np.isnan(out[:, J[joint]]).all():
                out[:, J[joint]] = lateral + (inwards if joint[0] == "r" else -inwards) * left
    rt, lt, top = (_marker(pts, xyz, n) for n in ("R.Temple", "L.Temple", "Top.Head"))
    if rt is not None and lt is not None and top is not None:
        mid = (rt + lt) / 2
        s = unit_rows(lt - rt)
        u = top - mid
        u = unit_across(u, s)
        f = np.cross(s, u)
        out[:, J["nose"]] = mid + 0.09 * f - 0.03 * u
        out[:, J["l_eye"]], out[:, J["r_eye"]] = mid + 0.06 * f + 0.032 * s, mid + 0.06 * f - 0.032 * s
        out[:, J["l_ear"]], out[:, J["r_ear"]] = lt - 0.03 * f - 0.02 * u, rt - 0.03 * f - 0.02 * u
    if np.isnan(out[:, [J["l_ankle"], J["r_ankle"]]]).all():
        raise InputError("TRC file has no ankle markers of a known marker set")
    pelvis = np.nanmean(out[:, [J["l_hip"], J["r_hip"]]], axis=1)
    return out, foot_points(pts, xyz, FOOT_MARKERS, out), pelvis
