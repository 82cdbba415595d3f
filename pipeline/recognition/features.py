"""Pre-processing of skeleton windows for the action model (pure functions).

The paper normalises translation and rotation so that the classifier does not
depend on where the user stands or which wall they face. Here a window of
frames ``(..., T, 17, 3)`` (metres, CAVE frame, NaN = unknown) becomes

1. translation-normalised: minus the window's mean pelvis (mid-hip) position, so
   the pelvis motion *inside* the window (sway, bob, side-steps) is kept;
2. rotation-normalised: turned about +Z so the window's mean facing direction
   (from hips and shoulders) points along +Y;
3. scale-normalised: divided by the window's torso length (mid-shoulder to
   mid-hip), so tall and short bodies look alike;
4. filled: unknown joints take their last known position in the normalised frame
   (the first known one before that, zero if never seen) and a mask channel says
   which were measured;
5. extended with velocities (per second at the model's frame rate, body units).

Every function works on any number of leading batch dimensions, so training
(``(N, T, 17, 3)``) and streaming inference (``(T, 17, 3)``) share the code.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from pipeline.recognition.steps import StepFrame
from pipeline.skeleton import NUM_JOINTS, J

# Per-joint channels given to the model: x, y, z, vx, vy, vz, known.
CHANNELS_PER_JOINT = 7
NUM_CHANNELS = NUM_JOINTS * CHANNELS_PER_JOINT
DEFAULT_TORSO_M = 0.5
_MIN_TORSO_M = 0.15

_L_HIP, _R_HIP = J["l_hip"], J["r_hip"]
_L_SH, _R_SH = J["l_shoulder"], J["r_shoulder"]


def _check_joints(joints: NDArray[np.floating]) -> NDArray[np.float64]:
    arr = np.asarray(joints, dtype=np.float64)
    if arr.ndim < 2 or arr.shape[-2:] != (NUM_JOINTS, 3):
        raise ValueError(f"joints must have shape (..., {NUM_JOINTS}, 3), got {arr.shape}")
    return arr


def _nan_mid(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Midpoint of two points (..., 3); the known one where the other is NaN."""
    out = np.where(np.isnan(a), b, a)
    both = ~np.isnan(a) & ~np.isnan(b)
    return np.where(both, 0.5 * (a + b), out)


def pelvis(joints: NDArray[np.floating]) -> NDArray[np.float64]:
    """Mid-hip position (..., 3); one hip if the other is unknown; NaN if both are."""
    arr = _check_joints(joints)
    return _nan_mid(arr[..., _L_HIP, :], arr[..., _R_HIP, :])


def facing_vectors(joints: NDArray[np.floating]) -> NDArray[np.float64]:
    """Unnormalised horizontal facing direction (..., 2) from hips and shoulders.

    COCO *left* is the person's own left: a person facing +Y has the left hip at
    -X, so the left-minus-right vector (-1, 0) turned clockwise by 90 degrees,
    (v_y, -v_x) = (0, 1), is the facing direction. Hips and shoulders are summed
    as unit vectors; a pair with a missing side contributes nothing. NaN when
    neither pair is complete.
    """
    arr = _check_joints(joints)
    total = np.zeros((*arr.shape[:-2], 2))
    count = np.zeros(arr.shape[:-2])
    for left, right in ((_L_HIP, _R_HIP), (_L_SH, _R_SH)):
        vx = arr[..., left, 0] - arr[..., right, 0]
        vy = arr[..., left, 1] - arr[..., right, 1]
        norm = np.sqrt(vx * vx + vy * vy)  # np.linalg.norm's sum, without its overhead (streaming)
        ok = np.isfinite(norm) & (norm > 1e-6)
        safe = np.where(ok, norm, 1.0)
        total[..., 0] += np.where(ok, vy / safe, 0.0)
        total[..., 1] += -np.where(ok, vx / safe, 0.0)
        count += ok
    return np.where((count > 0)[..., None], total, np.nan)


def yaw_from_vector(vec: NDArray[np.floating]) -> NDArray[np.float64]:
    """Yaw in degrees (CAVE convention: 0 = +Y, counter-clockwise positive) of (..., 2) vectors."""
    v = np.asarray(vec, dtype=np.float64)
    yaw = np.degrees(np.arctan2(-v[..., 0], v[..., 1])) + 0.0  # + 0.0: no negative zero
    return np.where(yaw <= -180.0, yaw + 360.0, yaw)


def window_yaw_deg(joints: NDArray[np.floating]) -> NDArray[np.float64]:
    """Mean facing yaw over the time axis of a window (..., T, 17, 3) -> (...); 0 when unknown."""
    return _mean_yaw_deg(_unit_facing(facing_vectors(joints)))


def _unit_facing(vec: NDArray[np.float64]) -> NDArray[np.float64]:
    """Facing vectors (..., 2) as unit vectors; (0, 0) where unknown."""
    norm = np.linalg.norm(vec, axis=-1, keepdims=True)
    unit = np.where(np.isfinite(norm) & (norm > 1e-9), vec / np.where(norm > 1e-9, norm, 1.0), 0.0)
    return np.nan_to_num(unit)


def _mean_yaw_deg(unit: NDArray[np.float64]) -> NDArray[np.float64]:
    """Yaw of the mean of unit facing vectors (..., T, 2) over the time axis; 0 when unknown."""
    mean = unit.sum(axis=-2)
    unknown = np.linalg.norm(mean, axis=-1) < 1e-9
    mean[unknown] = (0.0, 1.0)
    return yaw_from_vector(mean)


def rotation_z(yaw_deg: NDArray[np.floating] | float) -> NDArray[np.float64]:
    """Rotation matrices (..., 3, 3) about +Z by ``yaw_deg`` (counter-clockwise seen from above)."""
    a = np.radians(np.asarray(yaw_deg, dtype=np.float64))
    c, s = np.cos(a), np.sin(a)
    out = np.zeros((*a.shape, 3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 1, 0], out[..., 1, 1], out[..., 2, 2] = c, -s, s, c, 1.0
    return out


def torso_length(joints: NDArray[np.floating]) -> NDArray[np.float64]:
    """Mean mid-shoulder to mid-hip distance over the time axis (..., T, 17, 3) -> (...).

    The default (0.5 m) where it is never known or implausibly short.
    """
    arr = _check_joints(joints)
    return _mean_torso(_torso_lengths(arr, pelvis(arr)))


def _torso_lengths(arr: NDArray[np.float64], pel: NDArray[np.float64]) -> NDArray[np.float64]:
    """Mid-hip to mid-shoulder distances (...) of skeletons (..., 17, 3) whose pelvis is ``pel``."""
    return np.linalg.norm(_nan_mid(arr[..., _L_SH, :], arr[..., _R_SH, :]) - pel, axis=-1)


def _mean_torso(d: NDArray[np.float64]) -> NDArray[np.float64]:
    """Mean of torso lengths (..., T) over the time axis; the default where unknown or short."""
    ok = np.isfinite(d)
    count = ok.sum(axis=-1)
    mean = np.where(ok, d, 0.0).sum(axis=-1) / np.maximum(count, 1)
    return np.where((count > 0) & (mean > _MIN_TORSO_M), mean, DEFAULT_TORSO_M)


def normalize_window(joints: NDArray[np.floating]) -> NDArray[np.float64]:
    """Translation, rotation and scale normalisation of windows (..., T, 17, 3); NaN stays NaN."""
    arr = _check_joints(joints)
    if arr.ndim < 3:
        raise ValueError(f"a window needs a time axis: (..., T, 17, 3), got {arr.shape}")
    pel = pelvis(arr)  # (..., T, 3)
    return _normalize(arr, pel, _unit_facing(facing_vectors(arr)), _torso_lengths(arr, pel))


def _normalize(
    arr: NDArray[np.float64],
    pel: NDArray[np.float64],
    unit: NDArray[np.float64],
    torso: NDArray[np.float64],
) -> NDArray[np.float64]:
    """:func:`normalize_window` of windows (..., T, 17, 3) whose frames' pelvis (..., T, 3), unit
    facing vectors (..., T, 2) and torso lengths (..., T) are given."""
    ok = np.isfinite(pel).all(axis=-1, keepdims=True)
    n = ok.sum(axis=-2)
    centre = np.where(ok, pel, 0.0).sum(axis=-2) / np.maximum(n, 1)  # (..., 3)
    if not np.all(n > 0):  # no pelvis in some window: the mean of whatever is known
        flat = arr.reshape(*arr.shape[:-3], -1, 3)
        known = np.isfinite(flat).all(axis=-1, keepdims=True)
        other = np.where(known, flat, 0.0).sum(axis=-2) / np.maximum(known.sum(axis=-2), 1)
        centre = np.where(n > 0, centre, other)
    rot = rotation_z(-_mean_yaw_deg(unit))  # (..., 3, 3): facing -> +Y
    scale = _mean_torso(torso)
    centred = (arr - centre[..., None, None, :]).reshape(*arr.shape[:-3], -1, 3)
    rotated = (centred @ np.swapaxes(rot, -1, -2)).reshape(arr.shape)  # row vectors: x' = x R^T
    return rotated / scale[..., None, None, None]


def fill_unknown(joints: NDArray[np.floating]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Fill NaN joints along time (..., T, 17, 3): last known value, else first known, else 0.

    Returns (filled, known) with known (..., T, 17) True where the joint was measured.
    """
    arr = _check_joints(joints)
    finite = np.isfinite(arr)
    # all three coordinates finite (numpy's all() over a 3-long last axis costs more than two ands)
    known: NDArray[np.bool_] = finite[..., 0] & finite[..., 1] & finite[..., 2]
    filled = arr.copy()
    if known.all():
        return filled, known
    t = arr.shape[-3]
    steps = np.arange(t).reshape(t, 1)
    last = np.maximum.accumulate(np.where(known, steps, -1), axis=-2)  # (..., T, 17) newest known frame
    first = np.where(known.any(axis=-2), known.argmax(axis=-2), -1)  # (..., 17) the first known frame
    src = np.where(last >= 0, last, first[..., None, :])  # before the first known value: that value
    gaps = np.nonzero(~known)  # only the unknown joints are copied in: (..., frame, joint) indices
    frm = src[gaps]
    value = arr[(*gaps[:-2], np.maximum(frm, 0), gaps[-1])]
    filled[gaps] = np.where((frm >= 0)[:, None], value, 0.0)  # never known: 0
    return filled, known


def window_features(joints: NDArray[np.floating], fps: float) -> NDArray[np.float32]:
    """Model input features (..., T, 17, 7) of windows (..., T, 17, 3) sampled at ``fps``.

    Channels per joint: normalised x, y, z, their velocities (body units per second)
    and 1.0 where the joint was measured, 0.0 where it was filled in.
    """
    _check_fps(fps)
    return _features(normalize_window(joints), fps)


def _check_fps(fps: float) -> None:
    if not np.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps must be positive, got {fps}")


def _features(normalized: NDArray[np.float64], fps: float) -> NDArray[np.float32]:
    pos, known = fill_unknown(normalized)
    out = np.empty((*pos.shape[:-1], CHANNELS_PER_JOINT), np.float32)
    out[..., 0:3] = pos
    vel = (pos[..., 1:, :, :] - pos[..., :-1, :, :]) * fps
    vel *= (known[..., 1:, :] & known[..., :-1, :])[..., None]  # no velocity into or out of a gap
    out[..., 0, :, 3:6] = 0.0
    out[..., 1:, :, 3:6] = vel
    out[..., 6] = known
    return out


def _mid(a: float, b: float) -> float:
    """:func:`_nan_mid` of two numbers."""
    if math.isnan(a):
        return b
    if math.isnan(b):
        return a
    return 0.5 * (a + b)


class FrameParts(NamedTuple):
    """What a window's normalisation needs of one of its frames (metres, NaN = unknown)."""

    pelvis: tuple[float, float, float]
    facing: tuple[float, float]  # facing_vectors' row: unnormalised, NaN when unknown
    unit: tuple[float, float]  # facing as a unit vector, (0, 0) when unknown
    torso_m: float  # mid-hip to mid-shoulder


def _frame_rows(frame: NDArray[np.float64]) -> list[list[float]]:
    if frame.shape != (NUM_JOINTS, 3):
        raise ValueError(f"a frame must have shape ({NUM_JOINTS}, 3), got {frame.shape}")
    rows: list[list[float]] = frame.tolist()
    return rows


def facing_vector(frame: NDArray[np.float64]) -> tuple[float, float]:
    """One skeleton's (17, 3) row of :func:`facing_vectors`, with the same arithmetic in plain
    floats; NaN when neither hips nor shoulders are complete."""
    rows = _frame_rows(frame)
    return _facing(rows[_L_HIP], rows[_R_HIP], rows[_L_SH], rows[_R_SH])


def _facing(lh: list[float], rh: list[float], ls: list[float], rs: list[float]) -> tuple[float, float]:
    fx = fy = 0.0
    count = 0
    for left, right in ((lh, rh), (ls, rs)):
        vx = left[0] - right[0]
        vy = left[1] - right[1]
        norm = math.sqrt(vx * vx + vy * vy)
        if math.isfinite(norm) and norm > 1e-6:
            fx += vy / norm
            fy += -(vx / norm)
            count += 1
    return (fx, fy) if count else (math.nan, math.nan)


def frame_parts(frame: NDArray[np.float64]) -> FrameParts:
    """One skeleton's (17, 3) pelvis, facing and torso: the rows that :func:`pelvis`,
    :func:`facing_vectors` and :func:`normalize_window` compute for it, with the same arithmetic
    in plain floats (the same numbers; numpy's calls on one frame cost more than the arithmetic)."""
    rows = _frame_rows(frame)
    lh, rh, ls, rs = rows[_L_HIP], rows[_R_HIP], rows[_L_SH], rows[_R_SH]
    px, py, pz = _mid(lh[0], rh[0]), _mid(lh[1], rh[1]), _mid(lh[2], rh[2])
    tx, ty, tz = _mid(ls[0], rs[0]) - px, _mid(ls[1], rs[1]) - py, _mid(ls[2], rs[2]) - pz
    fx, fy = facing = _facing(lh, rh, ls, rs)
    unit = (0.0, 0.0)
    norm = math.sqrt(fx * fx + fy * fy)  # NaN when the facing is unknown
    if math.isfinite(norm) and norm > 1e-9:
        unit = (fx / norm, fy / norm)
    return FrameParts((px, py, pz), facing, unit, math.sqrt(tx * tx + ty * ty + tz * tz))


class RingWindow:
    """The newest ``size`` rows pushed to a stream, always one contiguous ``(size, *shape)`` array:
    a buffer of twice the size, each row written at both halves. Before ``size`` rows have come, the
    first is repeated in front (a window padded with its first frame)."""

    def __init__(self, size: int, shape: tuple[int, ...] = (), dtype: type[np.generic] = np.float64) -> None:
        if size < 1:
            raise ValueError(f"size must be at least 1, got {size}")
        self.size = size
        self._buf = np.empty((2 * size, *shape), dtype)
        self.clear()

    def __len__(self) -> int:
        """Rows pushed since the last clear (at most the size)."""
        return min(self._count, self.size)

    def clear(self) -> None:
        self._count = 0
        self._head = 0  # the slot of the oldest row of the newest window

    def push(self, row: Any) -> None:
        if self._count == 0:  # the first row fills the window: it is repeated in front
            self._buf[:] = row
            self._head = 1 % self.size
        else:
            slot = self._head
            self._buf[slot] = row
            self._buf[slot + self.size] = row
            self._head = (slot + 1) % self.size
        self._count += 1

    def view(self) -> NDArray[Any]:
        """The newest ``size`` rows, oldest first: a read-only view, valid until the next push;
        ValueError before the first row."""
        if not self._count:
            raise ValueError("no row yet")
        out = self._buf[self._head : self._head + self.size]
        out.flags.writeable = False
        return out


class FeatureWindow:
    """The features of a stream's newest ``window`` frames: :func:`window_features` of them (the
    same numbers; before the window is full, the first frame repeated in front).

    Each frame's pelvis, facing and torso are measured once, when it comes, not once per window it
    is in, and kept with the frame in :class:`RingWindow` buffers, so the newest window is one
    contiguous slice (nothing is stacked per frame).
    """

    def __init__(self, window: int, fps: float) -> None:
        if window < 2:
            raise ValueError(f"window must be at least 2 frames, got {window}")
        _check_fps(fps)
        self.window, self.fps = window, fps
        self._joints = RingWindow(window, (NUM_JOINTS, 3))
        self._pelvis = RingWindow(window, (3,))
        self._unit = RingWindow(window, (2,))
        self._torso = RingWindow(window)

    def __len__(self) -> int:
        """Frames pushed since the last clear (at most the window)."""
        return len(self._joints)

    def clear(self) -> None:
        for ring in (self._joints, self._pelvis, self._unit, self._torso):
            ring.clear()

    def push(self, frame: NDArray[np.float64]) -> None:
        """Add one frame (17, 3) float64 metres, NaN = unknown."""
        if frame.dtype != np.float64:  # the window keeps float64 (the batch path's numbers)
            raise ValueError(f"a frame must be float64, got {frame.dtype}")
        parts = frame_parts(frame)  # checks the shape
        self._joints.push(frame)
        self._pelvis.push(parts.pelvis)
        self._unit.push(parts.unit)
        self._torso.push(parts.torso_m)

    def features(self) -> NDArray[np.float32]:
        """(window, 17, 7) features of the newest frames; ValueError before the first frame."""
        if not len(self):
            raise ValueError("no frame yet")
        views = (self._joints.view(), self._pelvis.view(), self._unit.view(), self._torso.view())
        return _features(_normalize(*views), self.fps)


def to_model_input(features: NDArray[np.float32]) -> NDArray[np.float32]:
    """(..., T, 17, 7) features -> (..., 17*7, T), the joint-channel layout of the network."""
    f = _check_features(features)
    lead, t = f.shape[:-3], f.shape[-3]
    moved = np.moveaxis(f.reshape(*lead, t, NUM_CHANNELS), -1, -2)
    return np.ascontiguousarray(moved)


def _check_features(features: NDArray[np.float32]) -> NDArray[np.float32]:
    f = np.asarray(features, dtype=np.float32)
    if f.ndim < 3 or f.shape[-2:] != (NUM_JOINTS, CHANNELS_PER_JOINT):
        raise ValueError(f"features must have shape (..., T, 17, 7), got {f.shape}")
    return f


# ---------------------------------------------------------------- step evidence channels (features v2)
# Per frame, after the 17 x 7 joint channels: for each foot (left, right) planted, height above its
# standing level, lateral / sagittal / vertical displacement since lift-off (body frame at lift-off),
# swing time, body turn since lift-off; then jump and crouch. Lengths in leg lengths, times in
# seconds (clipped at 1), turns in half turns.

EVIDENCE_CHANNELS = 16
FEATURES_V1 = "v1"  # the 17 joints only
FEATURES_V2 = "v2"  # the 17 joints and the step evidence
FEATURES_V3 = "v3"  # v2's layout, the arms and the face masked out: legs, hips, shoulders + evidence
WITH_EVIDENCE = (FEATURES_V2, FEATURES_V3)
FEATURE_CHANNELS = {
    FEATURES_V1: NUM_CHANNELS,
    FEATURES_V2: NUM_CHANNELS + EVIDENCE_CHANNELS,
    FEATURES_V3: NUM_CHANNELS + EVIDENCE_CHANNELS,
}
# What a v3 model sees of the body: stepping is in the legs; the shoulders give the trunk's lean and
# turn. Arms and head move for a thousand reasons (a wave, a punch, looking around) that are not steps.
V3_JOINTS = tuple(J[n] for n in ("l_shoulder", "r_shoulder", "l_hip", "r_hip", "l_knee", "r_knee",
                                 "l_ankle", "r_ankle"))  # fmt: skip


def _clip(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else hi if v > hi else float(v)


def evidence_vector(frame: StepFrame) -> NDArray[np.float32]:
    """The (16,) evidence channels of one :class:`~pipeline.recognition.steps.StepFrame`."""
    leg = frame.leg_m
    vals: list[float] = []
    for f in frame.feet:
        h = f.height_m / leg if math.isfinite(f.height_m) else 0.0
        vals += (
            float(f.planted),
            _clip(h, -0.5, 1.0),
            _clip(f.lateral_m / leg, -1.0, 1.0),
            _clip(f.sagittal_m / leg, -1.0, 1.0),
            _clip(f.vertical_m / leg, 0.0, 1.0),
            min(f.swing_s, 1.0),
            f.turn_deg / 180.0,
        )
    vals.append(float(frame.feet[0].jump and frame.feet[1].jump))
    vals.append(_clip(frame.pelvis_ratio - 1.0, -1.0, 0.5))
    out = np.asarray(vals, dtype=np.float32)
    return out


def to_model_input_v2(features: NDArray[np.float32], evidence: NDArray[np.float32]) -> NDArray[np.float32]:
    """Joint features (..., T, 17, 7) and evidence (..., T, 16) -> (..., 17 * 7 + 16, T)."""
    f = _check_features(features)
    e = np.asarray(evidence, dtype=np.float32)
    lead, t = f.shape[:-3], f.shape[-3]
    if e.shape != (*lead, t, EVIDENCE_CHANNELS):
        raise ValueError(
            f"evidence must have shape (..., T, {EVIDENCE_CHANNELS}) like the features, got {e.shape}"
        )
    out = np.empty((*lead, NUM_CHANNELS + EVIDENCE_CHANNELS, t), np.float32)
    out[..., :NUM_CHANNELS, :] = np.swapaxes(f.reshape(*lead, t, NUM_CHANNELS), -1, -2)
    out[..., NUM_CHANNELS:, :] = np.swapaxes(e, -1, -2)
    return out


def mask_joints(features: NDArray[np.float32], keep: tuple[int, ...]) -> NDArray[np.float32]:
    """Joint features (..., T, 17, 7) with every joint not in ``keep`` zeroed (position, velocity and
    the known flag: the network sees it as never measured)."""
    out = np.zeros_like(features)
    out[..., list(keep), :] = features[..., list(keep), :]
    return out


def model_input(
    features: NDArray[np.float32], evidence: NDArray[np.float32] | None, version: str
) -> NDArray[np.float32]:
    """The network input of features version ``version``: (..., T, 17, 7) joint features and, for
    the versions with step evidence, (..., T, 16) evidence -> (..., channels, T)."""
    if version not in FEATURE_CHANNELS:
        raise ValueError(f"unknown features version {version!r}; known: {', '.join(FEATURE_CHANNELS)}")
    if version == FEATURES_V1:
        return to_model_input(features)
    if evidence is None:
        raise ValueError(f"features {version} need the step evidence of each window")
    if version == FEATURES_V3:
        features = mask_joints(features, V3_JOINTS)
    return to_model_input_v2(features, np.asarray(evidence, dtype=np.float32))
