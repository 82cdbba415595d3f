"""Published joint-angle curves over the gait cycle, as Fourier series.

Each curve is a table of key points (per cent of the gait cycle from the leg's own initial
contact -> degrees) read off the published mean curves, joined periodically by straight
lines, sampled at every per cent and fitted with a 5-harmonic Fourier series by least
squares (periodic and smooth, evaluated at any phase).

Walking, natural cadence (adult means):
- thigh angle to the vertical, knee flexion, ankle dorsiflexion: Winter, D. A. (1991),
  *The Biomechanics and Motor Control of Human Gait: Normal, Elderly and Pathological*,
  2nd ed., Univ. of Waterloo Press, and Winter (2009), *Biomechanics and Motor Control of
  Human Movement*, 4th ed., Wiley, ch. 4 and appendix A (segment and joint angles of the
  normal-cadence stride); toe-off at 62 % of the cycle.
- pelvic obliquity, rotation and tilt, shoulder (arm) swing: Perry, J. & Burnfield, J. M.
  (2010), *Gait Analysis: Normal and Pathological Function*, 2nd ed., SLACK, ch. 4 and 9
  (amplitudes about 4 deg, 4 deg, 2 deg; arm swing about 30 deg peak to peak).

Running (jogging, about 3.2 m/s): Novacheck, T. F. (1998), "The biomechanics of running",
*Gait & Posture* 7:77-95, Figs. 5-8 (sagittal hip, knee and ankle over the running cycle,
toe-off at about 39 %, peak swing knee flexion about 100 deg).

The values are approximate readings of those mean curves (a few degrees), which is what a
generator of plausible motion needs; they are not the published numbers to the decimal.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]
HARMONICS = 5

# (per cent of the gait cycle, degrees); initial contact at 0 %.
WALK_THIGH = (
    (0, 20), (10, 17), (20, 11), (30, 4), (40, -3), (50, -10), (57, -12), (62, -9), (70, 2),
    (77, 13), (85, 21), (90, 23), (95, 22),
)
WALK_KNEE = (
    (0, 3), (5, 10), (15, 18), (20, 17), (30, 10), (40, 5), (45, 6), (50, 10), (55, 20), (60, 35),
    (65, 50), (70, 59), (73, 61), (80, 53), (85, 38), (90, 20), (95, 8),
)
WALK_ANKLE = (
    (0, 0), (5, -4), (8, -5), (15, 0), (30, 6), (40, 9), (47, 10), (52, 6), (57, -5), (62, -16),
    (65, -15), (70, -8), (80, -2), (90, 0),
)
WALK_PELVIS_OBLIQUITY = ((0, 0), (15, 4), (30, 2), (50, 0), (65, -4), (80, -2))  # + = own side up
WALK_PELVIS_ROTATION = ((0, 4), (25, 0), (50, -4), (75, 0))  # + = own side forward
WALK_PELVIS_TILT = ((0, 0), (15, -1), (35, 1), (50, 0), (65, -1), (85, 1))
WALK_TOE_OFF = 0.62

RUN_THIGH = ((0, 25), (15, 15), (30, 0), (39, -12), (50, -5), (60, 15), (70, 35), (80, 45), (90, 40))
RUN_KNEE = (
    (0, 15), (10, 35), (20, 40), (30, 25), (39, 18), (50, 40), (60, 80), (70, 100), (80, 80), (90, 40),
)
RUN_ANKLE = ((0, 5), (10, 15), (20, 18), (30, 5), (39, -20), (50, -15), (60, 0), (70, 5), (80, 5), (90, 5))
RUN_TOE_OFF = 0.39


@dataclass(frozen=True, slots=True)
class Curve:
    """A periodic curve: ``value(phase)`` in radians, phase in cycles (any real)."""

    a0: float
    cos: F64
    sin: F64

    def __call__(self, phase: F64 | float) -> F64:
        p = 2 * np.pi * np.asarray(phase, dtype=float)[..., None]
        k = np.arange(1, len(self.cos) + 1)
        return np.asarray(self.a0 + (np.cos(k * p) * self.cos + np.sin(k * p) * self.sin).sum(-1))

    @property
    def mean(self) -> float:
        return self.a0


def fit(points: tuple[tuple[float, float], ...], harmonics: int = HARMONICS) -> Curve:
    """Least-squares Fourier fit of (per cent, degrees) key points; returns radians."""
    pct = np.array([p for p, _ in points], dtype=float)
    deg = np.array([d for _, d in points], dtype=float)
    dense_pct = np.arange(100.0)
    dense = np.interp(dense_pct, pct, deg, period=100.0)
    phase = 2 * np.pi * dense_pct[:, None] / 100.0
    k = np.arange(1, harmonics + 1)
    design = np.concatenate([np.ones((100, 1)), np.cos(k * phase), np.sin(k * phase)], axis=1)
    coef, *_ = np.linalg.lstsq(design, np.deg2rad(dense), rcond=None)
    return Curve(float(coef[0]), coef[1 : harmonics + 1], coef[harmonics + 1 :])


@dataclass(frozen=True, slots=True)
class GaitCurves:
    """One leg's sagittal curves and the pelvis for a gait (walking or running)."""

    thigh: Curve
    knee: Curve
    ankle: Curve
    obliquity: Curve
    rotation: Curve
    tilt: Curve
    toe_off: float


def walking() -> GaitCurves:
    return GaitCurves(
        fit(WALK_THIGH), fit(WALK_KNEE), fit(WALK_ANKLE), fit(WALK_PELVIS_OBLIQUITY),
        fit(WALK_PELVIS_ROTATION), fit(WALK_PELVIS_TILT), WALK_TOE_OFF,
    )


def running() -> GaitCurves:
    return GaitCurves(
        fit(RUN_THIGH), fit(RUN_KNEE), fit(RUN_ANKLE), fit(WALK_PELVIS_OBLIQUITY),
        fit(WALK_PELVIS_ROTATION), fit(WALK_PELVIS_TILT), RUN_TOE_OFF,
    )
