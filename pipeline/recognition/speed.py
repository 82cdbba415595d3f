"""Walking speed from stepping in place (pure functions).

Walking-in-place systems drive the virtual speed continuously from the step
frequency: ``speed = cadence x step length``, the step length per kind of step
(forward marching, side-stepping), optionally scaled by how high the feet are
lifted relative to a reference lift (``amplitude_gain`` > 0).

The cadence comes from the leg heights (knee plus ankle z, metres):

- marching (``forward``): the left-minus-right height difference rises through
  its mid-level when the left foot lifts and falls through it when the right one
  does: one crossing per step;
- side-stepping (``left`` / ``right``): the leading leg (the one on the side of the
  step) lifts once per step (out, then back).

Rising crossings use a dead band (hysteresis) so that noise makes no extra steps;
the cadence is one over the median interval. Fewer than two crossings, or legs lifted less
than ``min_lift_m`` (knee + ankle): a default cadence.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.skeleton import NUM_JOINTS, J

_LEGS = {"l": (J["l_knee"], J["l_ankle"]), "r": (J["r_knee"], J["r_ankle"])}


@dataclass(frozen=True, slots=True)
class SpeedConfig:
    """speed = cadence x step length (forward or side) x clip((lift / reference) ** gain, range)."""

    forward_step_m: float = 0.4
    side_step_m: float = 0.3
    amplitude_gain: float = 0.0
    reference_lift_m: float = 0.25
    amplitude_range: tuple[float, float] = (0.5, 1.5)
    min_lift_m: float = 0.04
    default_cadence_sps: float = 1.8
    min_cadence_sps: float = 0.8
    max_cadence_sps: float = 3.5

    def __post_init__(self) -> None:
        if self.forward_step_m <= 0 or self.side_step_m <= 0 or self.reference_lift_m <= 0:
            raise ValueError(
                "forward_step_m, side_step_m and reference_lift_m must be positive, got "
                f"{self.forward_step_m}, {self.side_step_m}, {self.reference_lift_m}"
            )
        if self.amplitude_gain < 0:
            raise ValueError(f"amplitude_gain must be >= 0, got {self.amplitude_gain}")
        lo, hi = self.amplitude_range
        if not 0 < lo <= hi:
            raise ValueError(f"amplitude_range must be 0 < lo <= hi, got {self.amplitude_range}")
        if not 0 < self.min_cadence_sps <= self.default_cadence_sps <= self.max_cadence_sps:
            raise ValueError(
                "expected 0 < min_cadence_sps <= default_cadence_sps <= max_cadence_sps, got "
                f"{self.min_cadence_sps}, {self.default_cadence_sps}, {self.max_cadence_sps}"
            )


def leg_height(frames: NDArray[np.floating], side: str) -> NDArray[np.float64]:
    """Knee + ankle height (T,) metres of the ``"l"`` or ``"r"`` leg; gaps linearly filled."""
    arr = np.asarray(frames, dtype=np.float64)
    if arr.ndim != 3 or arr.shape[1:] != (NUM_JOINTS, 3):
        raise ValueError(f"frames must have shape (T, 17, 3), got {arr.shape}")
    if side not in _LEGS:
        raise ValueError(f"side must be 'l' or 'r', got {side!r}")
    return gap_filled(arr[:, _LEGS[side], 2].sum(axis=1))


def leg_heights(frame: NDArray[np.float64]) -> tuple[float, float]:
    """One skeleton's (17, 3) left and right knee + ankle heights (NaN where unknown): the row
    :func:`leg_height` sums for it, so a stream can keep its signals frame by frame."""
    (lk, la), (rk, ra) = _LEGS["l"], _LEGS["r"]
    return float(frame[lk, 2]) + float(frame[la, 2]), float(frame[rk, 2]) + float(frame[ra, 2])


def gap_filled(signal: NDArray[np.float64]) -> NDArray[np.float64]:
    """A signal (T,) with its unknown samples linearly filled (zeros when none is known)."""
    ok = np.isfinite(signal)
    if ok.all():  # nothing to fill (np.interp at its own points gives the same numbers)
        return np.array(signal, dtype=np.float64)
    if not ok.any():
        return np.zeros(len(signal))
    idx = np.arange(len(signal))
    return np.interp(idx, idx[ok], signal[ok])


def _robust_range(signal: NDArray[np.float64]) -> tuple[float, float]:
    """5th and 95th percentiles (nearest rank; faster than np.percentile for short signals)."""
    s = np.sort(signal)
    n = s.size - 1
    return float(s[round(0.05 * n)]), float(s[round(0.95 * n)])


def rising_crossings(signal: NDArray[np.floating], fps: float, band: float = 0.25) -> NDArray[np.float64]:
    """Times (s) where the signal rises from below to above its mid-range.

    The mid-range is halfway between the 5th and 95th percentiles; a rise counts only from
    below ``mid - band x range`` to above ``mid + band x range``.
    """
    s = np.asarray(signal, dtype=np.float64)
    if s.size < 3:
        return np.zeros(0)
    lo, hi = _robust_range(s)
    mid, half = 0.5 * (lo + hi), band * (hi - lo)
    if hi - lo < 1e-6:
        return np.zeros(0)
    times: list[float] = []
    armed = False
    for i, v in enumerate(s.tolist()):  # plain floats: a numpy scalar per sample costs more
        if v < mid - half:
            armed = True
        elif v > mid + half and armed:
            times.append(i / fps)
            armed = False
    return np.asarray(times)


def lift_amplitude_m(signal: NDArray[np.floating]) -> float:
    """Robust range (5th to 95th percentile) of a leg-height signal."""
    s = np.asarray(signal, dtype=np.float64)
    if s.size < 2:
        return 0.0
    lo, hi = _robust_range(s)
    return hi - lo


def cadence_sps(times: NDArray[np.floating], steps_per_crossing: float, config: SpeedConfig) -> float:
    """Steps per second from rising-crossing times; the default with fewer than two crossings."""
    t = np.asarray(times, dtype=np.float64)
    if t.size < 2:
        return config.default_cadence_sps
    cad = steps_per_crossing / _median(np.diff(t).tolist())
    return min(max(cad, config.min_cadence_sps), config.max_cadence_sps)


def _median(values: list[float]) -> float:
    """np.median of a few numbers, in plain floats (the same number: the middle one, or the mean of
    the middle two; numpy's call costs more than the sort)."""
    s = sorted(values)
    mid = len(s) // 2
    return s[mid] if len(s) % 2 else (s[mid - 1] + s[mid]) / 2.0


def speed_mps(frames: NDArray[np.floating], fps: float, action: str, config: SpeedConfig) -> float:
    """Intended speed from recent frames (T, 17, 3) of someone doing ``action``; 0 for ``still``."""
    if fps <= 0:
        raise ValueError(f"fps must be positive, got {fps}")
    if action == "still":
        return 0.0
    return speed_from_heights(leg_height(frames, "l"), leg_height(frames, "r"), fps, action, config)


def speed_from_heights(
    left: NDArray[np.float64], right: NDArray[np.float64], fps: float, action: str, config: SpeedConfig
) -> float:
    """:func:`speed_mps` from the recent frames' :func:`leg_height` signals (T,) of both legs."""
    if fps <= 0:
        raise ValueError(f"fps must be positive, got {fps}")
    if action == "still":
        return 0.0
    kernel = np.ones(3) / 3.0  # a light moving average against triangulation noise
    left = np.convolve(left, kernel, mode="same")
    right = np.convolve(right, kernel, mode="same")
    if action == "forward":
        signal, step_m = left - right, config.forward_step_m
        # left lifts (rises of L - R) and right lifts (rises of R - L) alternate: one per step
        times = np.sort(np.concatenate([rising_crossings(signal, fps), rising_crossings(-signal, fps)]))
    elif action in ("left", "right"):
        signal, step_m = (left if action == "left" else right), config.side_step_m
        times = rising_crossings(signal, fps)
    else:
        raise ValueError(f"action must be still, forward, left or right, got {action!r}")
    amplitude = lift_amplitude_m(signal)
    if amplitude < config.min_lift_m:
        times = np.zeros(0)  # sway and weight shifts, no steps to time
    speed = cadence_sps(times, 1.0, config) * step_m
    if config.amplitude_gain > 0:
        lo, hi = config.amplitude_range
        ratio = amplitude / config.reference_lift_m
        speed *= float(np.clip(max(ratio, 1e-6) ** config.amplitude_gain, lo, hi))
    return float(speed)
