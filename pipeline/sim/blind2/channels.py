"""Per-frame posture channels of the blind2 body: their resting values and how behaviours blend in.

Each channel is a (T,) array (angles in radians, lengths in metres), initialised to a person's
resting value plus slow random sway, and then overwritten where a bout or a behaviour blends its
own value in with weights 0…1:

* ``kflex`` desired stance-knee flexion; ``sway`` how far the pelvis moves over the stance foot in
  single support (0…1); ``ws`` weight-shift bias along the left→right foot line (fraction);
  ``pdx``/``pdy`` pelvis offset right/forward in the pelvis frame; ``drop`` pelvis drop (squats);
* ``proll``/``pyaw`` pelvis roll and yaw offsets; ``tpitch``/``troll``/``ttwist`` trunk pitch
  (forward), roll and twist; ``hyaw``/``hpitch``/``hroll`` head yaw, pitch (down) and roll;
* per arm (``L``, ``R``): ``a`` plane of elevation, ``b`` elevation, ``e`` elbow flexion, ``r``
  humeral rotation; ``armA`` the amplitude of the marching arm counter-swing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.blind2.profiles import DEG, smooth_noise


class Channels:
    """The posture channels of one sequence of ``n_frames`` frames (mutable while a script is planned)."""

    __slots__ = ("n_frames", "values")

    def __init__(self, values: dict[str, NDArray[np.float64]], n_frames: int) -> None:
        if n_frames < 1:
            raise ValueError(f"n_frames must be at least 1, got {n_frames}")
        bad = sorted(k for k, v in values.items() if np.shape(v) != (n_frames,))
        if bad:
            raise ValueError(f"channels {bad} must have shape ({n_frames},)")
        self.values = values
        self.n_frames = n_frames

    def __getitem__(self, name: str) -> NDArray[np.float64]:
        return self.values[name]

    def blend(self, name: str, i0: int, val: float | NDArray[np.float64], w: NDArray[np.float64]) -> None:
        """From frame i0 on, channel ← channel·(1 − w) + val·w (w and an array val cut at the end)."""
        n = len(w)
        i1 = min(i0 + n, self.n_frames)
        w = w[: i1 - i0]
        if np.ndim(val) > 0:
            val = np.asarray(val)[: i1 - i0]
        seg = self.values[name][i0:i1]
        self.values[name][i0:i1] = seg * (1 - w) + val * w


@dataclass(frozen=True, slots=True)
class Balance:
    """Gains of the balance reactions: pelvis_drop_rad, how far the pelvis rolls down on the swing
    side, and trunk_lean_rad, how far the trunk leans toward the stance foot, in single support."""

    pelvis_drop_rad: float
    trunk_lean_rad: float

    def __post_init__(self) -> None:
        for name in ("pelvis_drop_rad", "trunk_lean_rad"):
            value = getattr(self, name)
            if not 0.0 <= value <= 10 * DEG:
                raise ValueError(f"{name} must be between 0 and 10 degrees, got {value}")


def resting_channels(rng: np.random.Generator, n_frames: int) -> Channels:
    """A person's resting posture with slow sway (the draws, in this order, are part of the output)."""
    r, T = rng, n_frames
    ch: dict[str, NDArray[np.float64]] = {}
    ch["kflex"] = np.full(T, r.uniform(4, 9) * DEG) + smooth_noise(r, T, 40, 1 * DEG)
    ch["sway"] = np.full(T, r.uniform(0.3, 0.8))
    ch["ws"] = smooth_noise(r, T, 45, r.uniform(0.02, 0.08))
    ch["pdx"] = smooth_noise(r, T, 25, 0.004)
    ch["pdy"] = smooth_noise(r, T, 25, 0.005)
    ch["drop"] = np.zeros(T)
    ch["proll"] = smooth_noise(r, T, 30, 0.5 * DEG)
    ch["pyaw"] = smooth_noise(r, T, 30, 1.5 * DEG)
    ch["tpitch"] = np.full(T, r.uniform(-2, 6) * DEG) + smooth_noise(r, T, 30, 1 * DEG)
    ch["troll"] = smooth_noise(r, T, 30, 0.8 * DEG)
    ch["ttwist"] = smooth_noise(r, T, 30, 1.5 * DEG)
    ch["hyaw"] = smooth_noise(r, T, 20, r.uniform(3, 10) * DEG)
    ch["hpitch"] = np.full(T, r.uniform(-5, 12) * DEG) + smooth_noise(r, T, 20, 3 * DEG)
    ch["hroll"] = smooth_noise(r, T, 25, 2 * DEG)
    for s in "LR":
        ch["a" + s] = np.full(T, r.uniform(-5, 20) * DEG) + smooth_noise(r, T, 30, 2 * DEG)
        ch["b" + s] = np.full(T, r.uniform(3, 14) * DEG) + smooth_noise(r, T, 30, 2 * DEG)
        ch["e" + s] = np.full(T, r.uniform(5, 30) * DEG) + smooth_noise(r, T, 30, 3 * DEG)
        ch["r" + s] = np.full(T, r.uniform(-5, 25) * DEG)
    ch["armA"] = np.zeros(T)
    return Channels(ch, T)


def sample_balance(rng: np.random.Generator) -> Balance:
    """A person's balance gains: pelvic drop 1–4°, trunk lean 0.5–3°."""
    drop = rng.uniform(1, 4) * DEG
    lean = rng.uniform(0.5, 3) * DEG
    return Balance(pelvis_drop_rad=drop, trunk_lean_rad=lean)
