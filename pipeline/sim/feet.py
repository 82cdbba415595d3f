"""Feet of simulated users: planned foot moves on the CAVE floor, rendered to ankle tracks and contacts.

A foot is *planted* (fixed on the floor, contact True) except while it makes a :class:`FootMove`:
a step's lift (or a shuffle's slide, or a jump's flight: contact False) or a glide that keeps
the foot bearing on the floor (a pivot's swivel, a marcher's foot sliding back: contact True).
Moves are planned in the CAVE floor frame, so a planted foot never slides with the body: the
pelvis follows the feet, never the other way round (:mod:`pipeline.sim.motion`).

:func:`bout_times` fits the steps of one bout into its segment: the first lift-off at the
segment's start, the last touch-down at its end (the LABELS convention of TEAM.md), with the
cadence, swing time, pauses and irregularity asked for.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.signals import bump, smoothstep

F64 = NDArray[np.float64]

LEFT, RIGHT = 0, 1
SIDE_SIGN = (-1.0, 1.0)  # each foot's side in the body frame (x to the person's right)
MAX_PAUSE_S = 1.0  # longest both-feet-down interval inside one bout (TEAM.md LABELS)
NATURAL_GAP_MAX_S = 0.75  # slow stepping lifts longer rather than waiting longer than this
MIN_SWING_S = 0.08
MIN_DOUBLE_S = 0.04  # both feet down at least this long between two steps (no hop) unless running


def forward_xy(yaw_rad: float) -> F64:
    """Facing direction on the floor for a yaw (0 = +Y, counter-clockwise positive)."""
    return np.array([-math.sin(yaw_rad), math.cos(yaw_rad)])


def right_xy(yaw_rad: float) -> F64:
    """The person's right on the floor for a yaw."""
    return np.array([math.cos(yaw_rad), math.sin(yaw_rad)])


@dataclass(frozen=True, slots=True)
class FootMove:
    """One move of one foot between two planted places (floor frame, ankle positions).

    foot: LEFT or RIGHT. t0 / t1: start and end, seconds (lift-off and touch-down of a step).
    xy0 / xy1: (2,) ankle position on the floor before and after; yaw0 / yaw1: foot direction, rad.
    lift_m: peak rise of the ankle. bulge_m: detour of the ankle along the foot's direction at
    mid-move (a marcher's ankle comes forward as the knee rises; negative: the heel kicks back).
    planted: the foot keeps bearing on the floor (glide or swivel; contact stays True).
    flight: a ballistic move (jumps): the lift is a parabola and the way is covered at a steady pace.
    """

    foot: int
    t0: float
    t1: float
    xy0: tuple[float, float]
    xy1: tuple[float, float]
    yaw0: float
    yaw1: float
    lift_m: float = 0.0
    bulge_m: float = 0.0
    planted: bool = False
    flight: bool = False


@dataclass(frozen=True, slots=True)
class FeetTrack:
    """Rendered feet over the frames.

    xy: (T, 2, 2) ankle floor positions [left, right]. yaw: (T, 2) foot directions, rad.
    lift: (T, 2) ankle rise over its standing height from moves. contact: (T, 2) bool, planted.
    swing: (T, 2) sin(pi s) over each non-planted move (0 when planted): how far into a step.
    base: (T, 2, 2) where each foot bears: its planted place, passing linearly from one to the
    next during a move (the body follows this, not the lifted ankle's detours).
    """

    xy: F64
    yaw: F64
    lift: F64
    contact: NDArray[np.bool_]
    swing: F64
    base: F64


class Feet:
    """Where each foot is planted and the moves planned so far (the planners' shared state)."""

    def __init__(self, xy: tuple[F64, F64], yaw_rad: tuple[float, float]) -> None:
        self.start_xy = (
            np.asarray(xy[0], dtype=np.float64).copy(),
            np.asarray(xy[1], dtype=np.float64).copy(),
        )
        self.start_yaw = (float(yaw_rad[0]), float(yaw_rad[1]))
        self.xy = [self.start_xy[0].copy(), self.start_xy[1].copy()]
        self.yaw = list(self.start_yaw)
        self.free = [-math.inf, -math.inf]  # when each foot's last move ends
        self.moves: list[FootMove] = []

    def move(
        self,
        foot: int,
        t0: float,
        t1: float,
        xy1: F64,
        yaw1: float | None = None,
        *,
        lift_m: float = 0.0,
        bulge_m: float = 0.0,
        planted: bool = False,
        flight: bool = False,
    ) -> None:
        """Plan a move of ``foot`` from where it is now; moves of one foot must not overlap."""
        if t0 < self.free[foot] - 1e-9:
            raise ValueError(
                f"foot {foot} moves at {t0:.3f} s before its last move ends ({self.free[foot]:.3f})"
            )
        t1 = max(float(t1), float(t0) + 1e-3)
        to = np.asarray(xy1, dtype=np.float64)
        yaw_to = self.yaw[foot] if yaw1 is None else float(yaw1)
        self.moves.append(
            FootMove(
                foot,
                float(t0),
                t1,
                (float(self.xy[foot][0]), float(self.xy[foot][1])),
                (float(to[0]), float(to[1])),
                self.yaw[foot],
                yaw_to,
                float(lift_m),
                float(bulge_m),
                planted,
                flight,
            )
        )
        self.xy[foot] = to.copy()
        self.yaw[foot] = yaw_to
        self.free[foot] = t1

    def render(self, t: F64) -> FeetTrack:
        n = t.shape[0]
        xy = np.empty((n, 2, 2))
        yaw = np.empty((n, 2))
        lift = np.zeros((n, 2))
        contact = np.ones((n, 2), dtype=bool)
        swing = np.zeros((n, 2))
        base = np.empty((n, 2, 2))
        for f in (LEFT, RIGHT):
            moves = [m for m in self.moves if m.foot == f]
            if not moves:
                xy[:, f] = base[:, f] = self.start_xy[f]
                yaw[:, f] = self.start_yaw[f]
                continue
            t0 = np.array([m.t0 for m in moves])
            t1 = np.array([m.t1 for m in moves])
            p0 = np.array([m.xy0 for m in moves])
            p1 = np.array([m.xy1 for m in moves])
            y0 = np.array([m.yaw0 for m in moves])
            y1 = np.array([m.yaw1 for m in moves])
            k = np.searchsorted(t0, t, side="right") - 1  # the latest move started by each frame
            started = k >= 0
            kk = np.maximum(k, 0)
            inside = started & (t < t1[kk])
            xy[:, f] = np.where(started[:, None], p1[kk], self.start_xy[f])
            yaw[:, f] = np.where(started, y1[kk], self.start_yaw[f])
            base[:, f] = xy[:, f]
            if not inside.any():
                continue
            ki = kk[inside]
            s = (t[inside] - t0[ki]) / (t1[ki] - t0[ki])
            flight = np.array([m.flight for m in moves])[ki]
            h = np.where(flight, s, smoothstep(s))
            z = np.where(flight, 4.0 * s * (1.0 - s), bump(s))
            heading = y0[ki] + (y1[ki] - y0[ki]) * h
            ahead = np.stack([-np.sin(heading), np.cos(heading)], -1)
            bulge = np.array([m.bulge_m for m in moves])[ki] * bump(s)
            xy[inside, f] = p0[ki] + h[:, None] * (p1[ki] - p0[ki]) + bulge[:, None] * ahead
            base[inside, f] = p0[ki] + s[:, None] * (p1[ki] - p0[ki])
            yaw[inside, f] = heading
            lift[inside, f] = np.array([m.lift_m for m in moves])[ki] * z
            stepping = ~np.array([m.planted for m in moves])[ki]
            contact[np.flatnonzero(inside)[stepping], f] = False
            swing[np.flatnonzero(inside)[stepping], f] = np.sin(np.pi * s[stepping])
        return FeetTrack(xy, yaw, lift, contact, swing, base)


def bout_times(
    rng: np.random.Generator,
    t_start: float,
    t_end: float,
    cadence: float,
    swing_frac: float,
    *,
    foot_of: Callable[[int], int],
    swing_mult: tuple[float, float] = (1.0, 1.0),
    pause_prob: float = 0.0,
    pause_s: tuple[float, float] = (0.2, MAX_PAUSE_S),
    irregularity: float = 0.0,
    same_foot: bool = False,
    even: bool = False,
    flight: bool = False,
) -> list[tuple[int, float, float]]:
    """(foot, lift-off, touch-down) of each step of one bout in [t_start, t_end].

    cadence: steps per second. swing_frac: the part of a step period a foot is in the air
    (above 1: the next foot lifts before this one lands, a flight phase as in running).
    swing_mult: per-foot swing-time factor (limping-like asymmetry). pause_prob: chance that a
    step is followed by a pause (both feet down for ``pause_s`` seconds). irregularity: relative
    random spread of step periods and swing times. same_foot: consecutive steps are made by one
    foot (it must land before it lifts again). even: prefer an even number of steps (out-and-back
    and step-together end with the feet together) unless that bends the cadence by over 12 %.
    flight: the next foot may lift before the last one lands (running); otherwise a foot is
    always down (at least ``MIN_DOUBLE_S`` of double support between steps).
    The first lift-off is at ``t_start`` and the last touch-down at ``t_end``; no both-feet-down
    interval inside the bout is longer than ``MAX_PAUSE_S``.
    """
    dur = t_end - t_start
    period = 1.0 / cadence
    swing0 = swing_frac * period
    if swing_frac <= 1.0:
        swing0 = min(period, max(swing0, period - NATURAL_GAP_MAX_S))
    n_max = int(dur / (0.4 * period)) + 3
    irr = max(0.0, irregularity)
    swings, gaps = np.empty(n_max), np.empty(n_max)
    for k in range(n_max):
        f = foot_of(k)
        s = swing0 * swing_mult[f] * float(np.clip(1.0 + 0.5 * irr * rng.standard_normal(), 0.6, 1.5))
        p = period * float(np.clip(1.0 + irr * rng.standard_normal(), 0.5, 1.6))
        g = p - s
        if same_foot or not flight:
            g = max(g, MIN_DOUBLE_S)
        if pause_prob > 0 and rng.random() < pause_prob:
            g = max(g + 0.15, float(rng.uniform(*pause_s)))
        swings[k], gaps[k] = max(s, MIN_SWING_S), min(g, MAX_PAUSE_S)
    ends = np.cumsum(swings + gaps) - gaps  # touch-down of step k, from t_start
    counts = np.arange(1, n_max + 1)
    n = int(counts[np.argmin(np.abs(ends - dur))])
    if even and n % 2 == 1 and n > 1:
        pair = counts[counts % 2 == 0]
        n_even = int(pair[np.argmin(np.abs(ends[pair - 1] - dur))])
        if abs(ends[n_even - 1] / dur - 1.0) < 0.12:  # else end with the foot out, at the cadence asked
            n = n_even
    sw, gp = swings[:n].copy(), gaps[: n - 1].copy()
    floor = -np.inf if flight else MIN_DOUBLE_S
    last = dur - (sw[:-1].sum() + gp.sum())  # what is left for the last step's swing
    if 0.6 * sw[-1] <= last <= 1.6 * sw[-1]:
        sw[-1] = last  # the cadence as asked; the last step lands a little sooner or later
    else:
        scale = dur / (sw.sum() + gp.sum())
        sw *= scale
        gp = np.maximum(gp * scale, floor)
        sw *= (dur - gp.sum()) / sw.sum()
    if gp.size and gp.max() > MAX_PAUSE_S:
        gp = np.minimum(gp, MAX_PAUSE_S)
        sw *= (dur - gp.sum()) / sw.sum()
    out = []
    t0 = t_start
    for k in range(n):
        t1 = t_end if k == n - 1 else t0 + sw[k]
        out.append((foot_of(k), t0, t1))
        if k < n - 1:
            t0 = t1 + gp[k]
    return out
