"""Standing idle and gestures (labelled ``still``); the rest of the still library is
:mod:`pipeline.sim.behaviours`.

- ``idle`` (tag "", or the gesture's name while one plays): postural sway, weight shifts
  (the pelvis over one foot, the other hip dropping), small knee dips, looking around, and arm
  gestures at the person's own rate: pointing, waving, crossing the arms, hands on the hips,
  touching the face.
- ``look-around``, ``point``, ``wave``: a still segment given to that gesture (1-3 times).

Feet stay planted (no foot move is planned). Sway plays always; the rest only where the
``still`` channel is on and no library behaviour keeps the person ``busy``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.plan import ArmPose, Ctx
from pipeline.sim.script import GESTURES, Segment
from pipeline.sim.signals import noise, smooth, smoothstep, window

F64 = NDArray[np.float64]

_GESTURE_WEIGHTS = np.array([0.25, 0.15, 0.15, 0.1, 0.1, 0.25])  # in GESTURES order
MIN_GESTURE_S = 0.8
GESTURE_BEHAVIOURS = {"look-around": "look_around", "point": "point", "wave": "wave"}


@dataclass(frozen=True, slots=True)
class Gesture:
    kind: str  # a name from GESTURES
    side: int  # -1 left arm, +1 right arm
    t0: float
    t1: float
    a: float  # kind-specific random parameters
    b: float

    @property
    def tag(self) -> str:
        return self.kind.replace("_", "-")


def _gesture(rng: np.random.Generator, kind: str, t0: float, t1: float) -> Gesture:
    side = 1 if rng.random() < 0.8 else -1
    if kind == "point":
        a, b = rng.uniform(0.0, np.radians(50)), rng.uniform(np.radians(-15), np.radians(30))
    elif kind == "wave":
        a, b = rng.uniform(1.5, 3.0), 0.0
    elif kind == "look_around":
        a = rng.choice([-1.0, 1.0]) * rng.uniform(np.radians(40), np.radians(85))
        b = rng.uniform(0.2, 0.6)
    else:
        a, b = 0.0, 0.0
    return Gesture(kind, side, t0, t1, float(a), float(b))


def schedule_gestures(rng: np.random.Generator, seg: Segment, start: float, rate_hz: float) -> list[Gesture]:
    """The gestures of one still segment: the script's list, its behaviour's, or at the person's rate."""
    end = start + seg.duration_s
    kinds: tuple[str, ...] | None = seg.gestures
    if seg.behaviour in GESTURE_BEHAVIOURS:
        kinds = (GESTURE_BEHAVIOURS[seg.behaviour],) * int(rng.integers(1, 4))
    if kinds is None and seg.behaviour not in (None, "idle"):
        return []  # a library behaviour: no random gestures on top
    if kinds is not None:
        slot = seg.duration_s / max(len(kinds), 1)
        out = []
        for i, kind in enumerate(kinds):
            dur = min(slot * 0.85, float(rng.uniform(1.5, 4.0)))
            if dur < MIN_GESTURE_S:
                continue  # no room to show it at a human pace
            c = start + (i + 0.5) * slot
            out.append(_gesture(rng, kind, c - dur / 2, c + dur / 2))
        return out
    if rate_hz <= 0:
        return []
    out = []
    cursor = start + float(rng.exponential(1.0 / rate_hz)) * 0.5
    while True:
        dur = float(rng.uniform(1.5, 4.5))
        if cursor + dur > end - 0.2:
            break
        kind = str(rng.choice(GESTURES, p=_GESTURE_WEIGHTS))
        out.append(_gesture(rng, kind, cursor, cursor + dur))
        cursor += dur + float(rng.exponential(1.0 / rate_hz))
    return out


def _weight_shifts(rng: np.random.Generator, t: F64) -> F64:
    """Held weight-shift levels in [-1, 1] (negative = weight on the left leg), smooth changes."""
    knots = [0.0]
    while knots[-1] < t[-1] + 1.0:
        knots.append(knots[-1] + float(rng.uniform(2.0, 8.0)))
    levels = np.where(rng.random(len(knots)) < 0.6, rng.uniform(-1.0, 1.0, len(knots)), 0.0)
    kn = np.asarray(knots)
    i = np.clip(np.searchsorted(kn, t, side="right") - 1, 0, len(kn) - 1)
    prev = levels[np.maximum(i - 1, 0)]
    out: F64 = prev + (levels[i] - prev) * smoothstep((t - kn[i]) / 0.7)
    return out


def _dips(rng: np.random.Generator, t: F64) -> F64:
    """Occasional small knee bends: pelvis drop in metres."""
    out = np.zeros_like(t)
    n = rng.poisson(0.04 * (t[-1] + 1.0))
    for c in rng.uniform(0.0, t[-1] + 1e-9, n):
        w = rng.uniform(0.4, 0.8)
        bell = np.where(np.abs(t - c) < w, 0.5 + 0.5 * np.cos(np.pi * (t - c) / w), 0.0)
        out += rng.uniform(0.02, 0.07) * bell
    return out


def idle_layer(ctx: Ctx, rng: np.random.Generator, gestures: list[Gesture]) -> None:
    """Sway (always), and while still: weight shifts, dips, looking around and the gestures."""
    ch, style, body = ctx.ch, ctx.style, ctx.body
    t = ch.t
    fps = 1.0 / float(t[1] - t[0]) if t.size > 1 else 30.0
    still = ch.still * (1.0 - np.clip(smooth(ch.busy, 0.15 * fps), 0.0, 1.0))
    ch.pelvis[:, 0] += style.sway_m * noise(rng, t, 0.1, 0.4)
    ch.pelvis[:, 1] += style.sway_m * noise(rng, t, 0.1, 0.4)
    ws = _weight_shifts(rng, t) * still
    dip = _dips(rng, t) * still
    ch.pelvis[:, 0] += 0.035 * ws
    ch.pelvis[:, 1] -= 0.01 * dip / 0.07
    ch.pelvis[:, 2] -= dip
    ch.pelvis_roll += -np.radians(2.5) * ws
    ch.trunk_pitch += np.radians(10.0) * dip / 0.07
    head_yaw = np.radians(style.look_deg) * noise(rng, t, 0.03, 0.2) * (0.4 + 0.6 * still)
    ch.head_pitch += np.radians(8.0) * noise(rng, t, 0.05, 0.3) + np.radians(4.0) * (1.0 - still)
    h = body.height_m / 1.75
    for g in gestures:
        ramp = min(0.5, (g.t1 - g.t0) / 3)
        w = window(t, g.t0, g.t1, ramp) * still
        c = g.side
        if g.kind == "look_around":
            wl = window(t, g.t0, g.t1, min(0.6, (g.t1 - g.t0) / 3)) * still
            head_yaw = head_yaw + wl * g.a * (1.0 - g.b + g.b * np.sin(2 * np.pi * 0.3 * (t - g.t0)))
            continue
        if g.kind == "point":
            head_yaw = head_yaw - 0.7 * w * c * g.a
            d = np.array([c * np.sin(g.a) * np.cos(g.b), np.cos(g.a) * np.cos(g.b), np.sin(g.b)])
            reach = body.upper_arm_m + body.forearm_m * 0.998
            ch.arms.append(ArmPose(c, w, d * reach, "trunk", (c * 0.6, -0.4, -1.0)))
        elif g.kind == "wave":
            wobble = 0.07 * np.sin(2 * np.pi * g.a * (t - g.t0))
            off = np.stack([c * (0.22 + wobble), np.full_like(t, 0.08), np.full_like(t, 0.33)], -1) * h
            ch.arms.append(ArmPose(c, w, off, "trunk", (c * 1.0, -0.6, -0.6)))
        elif g.kind == "cross_arms":
            for arm in (-1, 1):
                sw = body.shoulder_width_m
                off = np.array(
                    [
                        -arm * (sw / 2 - 0.04) - arm * sw / 2,
                        0.16 if arm < 0 else 0.2,
                        -0.27 if arm < 0 else -0.23,
                    ]
                )
                ch.arms.append(ArmPose(arm, w, off, "trunk", (arm * 1.0, 0.2, -1.0)))
        elif g.kind == "hands_on_hips":
            for arm in (-1, 1):
                ch.arms.append(
                    ArmPose(arm, w, np.array([arm * 0.07, -0.02, 0.06]), "hip", (arm * 1.0, -0.6, 0.0))
                )
        else:  # touch_face
            ch.arms.append(ArmPose(c, w, np.array([c * 0.02, 0.11, -0.1]), "head", (c * 0.5, 0.0, -1.0)))
    ch.head_yaw += head_yaw
    ch.trunk_twist += 0.25 * head_yaw * still


def tag_gestures(ctx: Ctx, gestures: list[Gesture]) -> None:
    """Idle frames inside a gesture take the gesture's name as their tag."""
    for g in gestures:
        for i in np.flatnonzero(ctx.ch.span(g.t0, g.t1)).tolist():
            if ctx.ch.tags[i] == "":
                ctx.ch.tags[i] = g.tag
