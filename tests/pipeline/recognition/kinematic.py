"""Hand-made kinematic skeletons with exactly known foot contacts, for the step-evidence tests.

Not a benchmark and not a training source: a few lines of geometry whose ground truth is known
by construction (when each foot lifts and lands, where it goes), independent of every simulator.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from pipeline.skeleton import J

from .conftest import standing_pose

UPPER = [J[n] for n in ("nose", "l_eye", "r_eye", "l_ear", "r_ear", "l_shoulder", "r_shoulder",
                        "l_elbow", "r_elbow", "l_wrist", "r_wrist")]  # fmt: skip
ANKLES = (J["l_ankle"], J["r_ankle"])
KNEES = (J["l_knee"], J["r_knee"])
HIPS = (J["l_hip"], J["r_hip"])


@dataclass(frozen=True)
class Swing:
    """One foot's step: from t0 to t1 seconds the foot moves by (lateral, sagittal) metres in the
    body frame (+right, +forward) and rises to ``peak`` metres in the middle."""

    foot: int  # 0 left, 1 right
    t0: float
    t1: float
    lateral: float = 0.0
    sagittal: float = 0.0
    peak: float = 0.1


@dataclass(frozen=True)
class Scene:
    duration_s: float
    swings: tuple[Swing, ...] = ()
    height_m: float = 1.75
    yaw_deg: float = 0.0
    floor_z: float = 0.0  # the whole body offset (an unknown floor height)
    crouch: tuple[tuple[float, float, float], ...] = ()  # (t0, t1, depth m): pelvis lowered, feet planted
    jumps: tuple[tuple[float, float, float], ...] = ()  # (t0, t1, height m): whole body up, both feet
    heel_rise: tuple[tuple[float, float, float], ...] = ()  # (t0, t1, height m): both ankles slowly up
    wave: bool = False
    fps: float = 30.0
    extra: dict[str, float] = field(default_factory=dict)


def _bump(s: NDArray[np.float64]) -> NDArray[np.float64]:
    """0 -> 1 -> 0 over s in [0, 1] (sin^2 shape), 0 outside."""
    inside = (s >= 0) & (s <= 1)
    return np.where(inside, np.sin(np.pi * np.clip(s, 0, 1)) ** 2, 0.0)


def _ramp(s: NDArray[np.float64]) -> NDArray[np.float64]:
    c = np.clip(s, 0.0, 1.0)
    return c * c * (3 - 2 * c)


def _plateau(t: NDArray[np.float64], t0: float, t1: float, ramp: float) -> NDArray[np.float64]:
    return _ramp((t - t0) / ramp) * (1 - _ramp((t - (t1 - ramp)) / ramp))


def render(scene: Scene) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """(T, 17, 3) joints in the CAVE frame and (T, 2) ground-truth contacts [left, right]."""
    n = round(scene.duration_s * scene.fps)
    t = np.arange(n) / scene.fps
    s = scene.height_m / 1.75
    base = standing_pose() * s  # facing +Y, at the origin
    out = np.repeat(base[None], n, axis=0)
    contacts = np.ones((n, 2), dtype=bool)
    feet_xy = np.zeros((n, 2, 2))  # displacement of each foot, body frame (lateral, sagittal)
    feet_z = np.zeros((n, 2))
    for sw in scene.swings:
        u = (t - sw.t0) / (sw.t1 - sw.t0)
        inside = (u > 0) & (u < 1)
        contacts[inside, sw.foot] = False
        prog = _ramp(u)
        feet_xy[:, sw.foot, 0] += prog * sw.lateral
        feet_xy[:, sw.foot, 1] += prog * sw.sagittal
        feet_z[:, sw.foot] += _bump(u) * sw.peak
    # feet move: ankles, knees follow halfway and bend forward with the lift
    for k in (0, 1):
        out[:, ANKLES[k], 0] += feet_xy[:, k, 0]
        out[:, ANKLES[k], 1] += feet_xy[:, k, 1]
        out[:, ANKLES[k], 2] += feet_z[:, k]
        out[:, KNEES[k], 0] += 0.5 * feet_xy[:, k, 0]
        out[:, KNEES[k], 1] += 0.5 * feet_xy[:, k, 1] + 0.8 * feet_z[:, k]
        out[:, KNEES[k], 2] += feet_z[:, k]  # marching: the thigh lifts, the shank hangs
    # the pelvis follows the feet sideways by half (weight over the feet)
    mid = 0.5 * feet_xy.sum(axis=1)
    body = [*UPPER, *HIPS]
    out[:, body, 0] += mid[:, None, 0]
    out[:, body, 1] += mid[:, None, 1]
    for t0, t1, depth in scene.crouch:
        d = depth * _plateau(t, t0, t1, 0.6)
        out[:, [*UPPER, *HIPS], 2] -= d[:, None]
        out[:, list(KNEES), 2] -= 0.5 * d[:, None]
        out[:, list(KNEES), 1] += 0.6 * d[:, None]
    for t0, t1, height in scene.heel_rise:
        d = height * _plateau(t, t0, t1, 1.0)
        out[:, :, 2] += d[:, None]  # everything rises with the heels; the toes stay down
    for t0, t1, height in scene.jumps:
        u = (t - t0) / (t1 - t0)
        inside = (u > 0) & (u < 1)
        contacts[inside] = False
        out[:, :, 2] += (_bump(u) * height)[:, None]
    if scene.wave:
        w = J["r_wrist"]
        out[:, w, 2] = base[w, 2] + 0.6 * s + 0.1 * np.sin(2 * np.pi * 1.5 * t)
        out[:, w, 0] = base[w, 0] + 0.15 * np.sin(2 * np.pi * 1.5 * t)
    a = np.radians(scene.yaw_deg)
    rot = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    out = out @ rot.T
    out[..., 2] += scene.floor_z
    return out, contacts


def noisy(
    joints: NDArray[np.float64], sigma_m: float, drop: float = 0.0, seed: int = 0
) -> NDArray[np.float64]:
    """White noise of ``sigma_m`` per axis and a share ``drop`` of joints unknown (NaN)."""
    rng = np.random.default_rng(seed)
    out = joints + rng.normal(0.0, sigma_m, joints.shape)
    out[rng.random(joints.shape[:2]) < drop] = np.nan
    return out


def march(t0: float, steps: int, period: float, swing: float, peak: float = 0.1) -> tuple[Swing, ...]:
    """Alternating steps in place (left first) every ``period`` seconds, each swing ``swing`` long."""
    return tuple(Swing(i % 2, t0 + i * period, t0 + i * period + swing, peak=peak) for i in range(steps))


def kick(
    joints: NDArray[np.float64], swing: Swing, raise_deg: float, sideways: bool = False, fps: float = 30.0
) -> NDArray[np.float64]:
    """``joints`` with the swing's leg raised straight about its hip during the swing, up to
    ``raise_deg`` from where it hangs in the middle (a front kick; ``sideways``: out to the foot's
    side). For a scene rendered facing +Y (yaw 0)."""
    out = joints.copy()
    t = np.arange(len(joints)) / fps
    a = np.radians(raise_deg) * np.sin(np.pi * np.clip((t - swing.t0) / (swing.t1 - swing.t0), 0.0, 1.0))
    axis = 0 if sideways else 1  # the horizontal axis the ankle moves along: x (right) or y (forward)
    sign = (1.0 if swing.foot == 1 else -1.0) if sideways else 1.0
    hip = out[:, HIPS[swing.foot]]
    for j in (KNEES[swing.foot], ANKLES[swing.foot]):
        v = out[:, j] - hip
        h, z = v[:, axis], v[:, 2]
        out[:, j, axis] = hip[:, axis] + h * np.cos(a) - sign * z * np.sin(a)
        out[:, j, 2] = hip[:, 2] + sign * h * np.sin(a) + z * np.cos(a)
    return out
