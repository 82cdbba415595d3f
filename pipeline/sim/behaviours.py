"""The still library: what people do in a CAVE without meaning to move (all labelled ``still``).

Each behaviour fills its segment and is back to standing by the segment's end (where it began,
but for ``step-back``); ``intensity`` (0-1, the script's or drawn) scales how far it goes between
the ranges below (body-relative where it says L = thigh + shin). Tags are the behaviour's name;
the rising part of a crouch, squat or kneel is tagged ``stand-up``.

- ``crouch``: pelvis down 0.20-0.45 L, hips back, trunk forward 15-40 deg; hands forward,
  on the knees or one touching the floor. Feet planted.
- ``squat``: pelvis down 0.45-0.62 L, knees out 10-30 deg, heels up 0-4 cm, arms forward.
  Feet planted (toes on the floor).
- ``kneel``: on one knee: the rear foot steps back, the pelvis goes down until the rear knee
  is on the floor (rear heel up, toes down), the front shin upright-ish; then up, and the rear
  foot steps forward again. The feet move only in those two steps.
- ``kneel-forward``: the same kneel reached the other way: the front foot steps forward, the
  rear knee goes down where the rear foot stood; then up, and the front foot steps back. Not in
  the routines' random draws yet (``ranges``): a script names it (the recogniser's known limit,
  MODEL_CARD.md "Limits").
- ``lunge``: to reach for something, punch, strike or look closer: one foot steps 0.3-0.6 m
  forward (body scaled, a little to its side), the body goes onto it (the pelvis forward past the
  feet's midpoint and 3-10 % of the leg lower, trunk 10-30 deg forward), one arm reaches or punches
  out ahead; held, then the front foot steps back home. Not in the routines' random draws
  (``ranges``): a script names it (the behaviour test that a lunge is at most a short nudge).
- ``step-back``: making room or backing off from a wall: one foot steps back 0.25-0.5 m (body
  scaled), the other follows beside it, and the person stays there (a real step back is no
  command: there is no ``backward``). Not in the routines' random draws (``ranges``): a script
  names it (the behaviour test that no step back moves the user).
- ``bend``: to pick something up: trunk forward 50-100 deg, knees bent, hips back, one or both
  hands to a spot on the floor ahead, looking down. Feet planted.
- ``lean``: far, forward or to a side (20-45 deg), the pelvis shifting the other way, one arm
  reaching; a side lean lifts the far heel a little. Feet planted.
- ``tiptoe``: heels up 3-8 cm once or in 1-3 bounces, often reaching up and looking up.
  Toes planted.
- ``jump``: 1-3 jumps: a countermovement dip, take-off and landing with both feet together
  (flight 0.25-0.45 s, feet displaced 0-20 cm together), absorbing the landing; arms swing.
- ``sway``: the whole body sways slowly (2-6 cm, 0.2-0.6 Hz), feet planted.
- ``dance-on-spot``: to a beat of 1.6-2.4 Hz: knee bounce, hip sway, torso twist, arms and
  head moving; feet planted.
- ``weight-shift``: the weight goes from foot to foot and is held there (the unloaded knee
  bends, its heel may rise 0-1.5 cm); feet planted.
- ``stretch``: arms overhead (back arched), arms out to the sides, a side bend with one arm
  over the head, or a trunk twist; feet planted (overhead: sometimes on tiptoe).
- ``look-around``, ``point``, ``wave``: gestures (:mod:`pipeline.sim.idle`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.feet import LEFT, RIGHT, SIDE_SIGN, forward_xy, right_xy
from pipeline.sim.plan import ArmPose, Ctx
from pipeline.sim.script import Segment
from pipeline.sim.signals import smoothstep

F64 = NDArray[np.float64]

G = 9.81


def _env(t: F64, t0: float, t1: float, down_s: float, up_s: float) -> F64:
    """0 -> 1 over [t0, t0 + down_s], 1, then 1 -> 0 over [t1 - up_s, t1]."""
    out: F64 = smoothstep((t - t0) / max(down_s, 1e-6)) * smoothstep((t1 - t) / max(up_s, 1e-6))
    return out


def _between(k: float, lo: float, hi: float) -> float:
    return lo + (hi - lo) * k


def _phase_s(dur: float, lo: float, hi: float, rng: np.random.Generator, share: float = 0.35) -> float:
    """A transition time drawn in [lo, hi] s but at most ``share`` of the segment."""
    return min(float(rng.uniform(lo, hi)), share * dur)


def _arm(
    ctx: Ctx, side: int, w: F64, target: F64 | tuple[float, ...], frame: str, pole: tuple[float, ...]
) -> None:
    ctx.ch.arms.append(
        ArmPose(side, w, np.asarray(target, dtype=np.float64), frame, (pole[0], pole[1], pole[2]))
    )


def _stand_up_tag(ctx: Ctx, t_rise: float, t1: float) -> None:
    ctx.ch.tag(t_rise, t1, "stand-up")


def _crouch(ctx: Ctx, seg: Segment, t0: float, t1: float, k: float) -> None:
    ch, rng, body = ctx.ch, ctx.rng, ctx.body
    leg = body.thigh_m + body.shin_m
    dur = t1 - t0
    down, up = _phase_s(dur, 0.5, 1.2, rng), _phase_s(dur, 0.5, 1.2, rng)
    w = _env(ch.t, t0, t1, down, up)
    drop = _between(k, 0.20, 0.45) * leg
    ch.pelvis[:, 2] -= drop * w
    ch.pelvis[:, 1] -= 0.3 * drop * w
    ch.trunk_pitch += math.radians(_between(k, 15.0, 40.0)) * w
    ch.head_pitch -= math.radians(15.0) * w  # keeps looking ahead
    ch.knee_out += math.radians(float(rng.uniform(0.0, 12.0))) * w[:, None]
    _arms_low(ctx, w, rng)
    _stand_up_tag(ctx, t1 - up, t1)


def _arms_low(ctx: Ctx, w: F64, rng: np.random.Generator) -> None:
    """Hands forward for balance, on the knees, or one touching the floor."""
    choice = rng.random()
    h = ctx.body.height_m / 1.75
    for side in (-1, 1):
        if choice < 0.35:
            _arm(ctx, side, w, (side * 0.12 * h, 0.45 * h, -0.15 * h), "trunk", (side * 0.5, -0.5, -1.0))
        elif choice < 0.75:
            _arm(ctx, side, w, (0.0, 0.06, 0.04), "knee", (side * 1.0, -0.3, -0.5))
        elif side == 1:
            _arm(ctx, side, w, (0.2 * h, 0.35 * h, 0.06), "body", (1.0, -0.5, 0.0))


def _squat(ctx: Ctx, seg: Segment, t0: float, t1: float, k: float) -> None:
    ch, rng, body = ctx.ch, ctx.rng, ctx.body
    leg = body.thigh_m + body.shin_m
    dur = t1 - t0
    down, up = _phase_s(dur, 0.6, 1.4, rng), _phase_s(dur, 0.6, 1.4, rng)
    w = _env(ch.t, t0, t1, down, up)
    drop = _between(k, 0.45, 0.62) * leg
    ch.pelvis[:, 2] -= drop * w
    ch.pelvis[:, 1] -= 0.25 * drop * w
    ch.trunk_pitch += math.radians(_between(k, 25.0, 45.0)) * w
    ch.head_pitch -= math.radians(20.0) * w
    ch.knee_out += math.radians(float(rng.uniform(10.0, 30.0))) * w[:, None]
    heel = float(rng.uniform(0.0, 0.04)) * k
    ch.heel += heel * w[:, None]
    ch.pelvis[:, 2] += heel * w
    h = body.height_m / 1.75
    for side in (-1, 1):
        _arm(ctx, side, w, (side * 0.1 * h, 0.5 * h, 0.0), "trunk", (side * 0.5, -0.5, -1.0))
    _stand_up_tag(ctx, t1 - up, t1)


def _kneel(ctx: Ctx, seg: Segment, t0: float, t1: float, k: float, front_steps: bool = False) -> None:
    """One knee down: the rear foot steps back (``front_steps``: the front foot steps forward) so
    that, the pelvis lowered, the knee meets the floor."""
    ch, rng, body = ctx.ch, ctx.rng, ctx.body
    rear = int(rng.integers(2))
    front = 1 - rear
    yaw = ch.yaw_at(t0)
    fwd, right = forward_xy(yaw), right_xy(yaw)
    scale = body.height_m / 1.75
    knee_z, ankle_z = 0.055 * scale, float(rng.uniform(0.09, 0.12)) * scale  # knee on the floor, heel up
    tilt = math.radians(_between(k, 20.0, 5.0))  # rear thigh from the vertical
    hip_z = knee_z + body.thigh_m * math.cos(tilt)
    back = float(rng.uniform(0.55, 0.85)) * body.thigh_m  # the pelvis behind the front foot
    front_xy = ctx.feet.xy[front]
    f_along, f_side = float(front_xy @ fwd), float(front_xy @ right)
    hip_y = -back
    knee_y = hip_y + body.thigh_m * math.sin(tilt)
    ankle_y = knee_y - math.sqrt(body.shin_m**2 - (ankle_z - knee_z) ** 2)
    spread = ctx.width_m * float(rng.uniform(0.6, 1.0))
    rear_side = f_side - SIDE_SIGN[front] * spread
    mover, target = rear, (f_along + ankle_y) * fwd + rear_side * right
    if front_steps:  # the rear foot stays; the front one steps out ahead of it
        rear_xy = ctx.feet.xy[rear]
        r_along, rear_side = float(rear_xy @ fwd), float(rear_xy @ right)
        f_along, f_side = r_along - ankle_y, rear_side + SIDE_SIGN[front] * spread
        mover, target = front, f_along * fwd + f_side * right
    dur = t1 - t0
    step_s = _phase_s(dur, 0.5, 0.8, rng, 0.2)
    down_s = _phase_s(dur, 0.6, 1.1, rng, 0.25)
    up_s = _phase_s(dur, 0.6, 1.1, rng, 0.25)
    s_back0 = t0 + 0.02
    s_back1 = s_back0 + step_s
    s_fwd1 = t1 - 0.02
    s_fwd0 = s_fwd1 - step_s
    home = ctx.feet.xy[mover].copy()
    ctx.feet.move(
        mover, s_back0, s_back1, target, ctx.feet_yaw(yaw, mover), lift_m=float(rng.uniform(0.03, 0.08))
    )
    ctx.feet.move(
        mover, s_fwd0, s_fwd1, home, ctx.feet_yaw(yaw, mover), lift_m=float(rng.uniform(0.03, 0.08))
    )
    w = _env(ch.t, s_back0 + 0.3 * step_s, s_fwd0 + 0.2 * step_s, down_s, up_s)
    # pelvis offsets from where the feet's midpoint is while kneeling: the rear hip above the knee
    mid_along = f_along + 0.5 * ankle_y
    mid_side = 0.5 * (f_side + rear_side)
    pelvis_side = rear_side - SIDE_SIGN[rear] * 0.5 * body.hip_width_m
    ch.pelvis[:, 1] += (f_along + hip_y - mid_along) * w
    ch.pelvis[:, 0] += (pelvis_side - mid_side) * w
    ch.pelvis[:, 2] += (hip_z - body.hip_height_m) * w
    ch.heel[:, rear] += (ankle_z - body.ankle_height_m) * w
    ch.trunk_pitch += math.radians(float(rng.uniform(0.0, 12.0))) * w
    ch.head_pitch -= math.radians(10.0) * w
    side = SIDE_SIGN[front]
    _arm(ctx, int(side), w, (0.0, 0.05, 0.05), "knee", (side * 1.0, -0.3, -0.5))
    _stand_up_tag(ctx, s_fwd0 + 0.2 * step_s - up_s, t1)


def _step_back(ctx: Ctx, seg: Segment, t0: float, t1: float, k: float) -> None:
    """One foot steps back, the other closes beside it; the person stays in the new place."""
    ch, rng, body = ctx.ch, ctx.rng, ctx.body
    yaw = ch.yaw_at(t0)
    back = _between(k, 0.25, 0.5) * body.height_m / 1.75 * forward_xy(yaw)
    lead = int(rng.integers(2))
    dur = t1 - t0
    step_s = _phase_s(dur, 0.45, 0.7, rng, 0.2)
    start = t0 + 0.02
    follow = start + step_s + float(rng.uniform(0.0, 0.3))  # the other lifts as or after the first lands
    for foot, lift in ((lead, start), (1 - lead, follow)):
        ctx.feet.move(
            foot, lift, lift + step_s, ctx.feet.xy[foot] - back, ctx.feet_yaw(yaw, foot),
            lift_m=float(rng.uniform(0.02, 0.08)),
        )  # fmt: skip


def _lunge(ctx: Ctx, seg: Segment, t0: float, t1: float, k: float) -> None:
    """One foot steps out ahead, the body goes onto it with an arm reaching out; then back home."""
    ch, rng, body = ctx.ch, ctx.rng, ctx.body
    yaw = ch.yaw_at(t0)
    fwd, right = forward_xy(yaw), right_xy(yaw)
    scale = body.height_m / 1.75
    front = int(rng.integers(2))
    ahead = _between(k, 0.3, 0.6) * scale
    out = float(rng.uniform(0.0, 0.06)) * SIDE_SIGN[front]
    home = ctx.feet.xy[front].copy()
    dur = t1 - t0
    step_s = _phase_s(dur, 0.4, 0.7, rng, 0.2)
    s_out0 = t0 + 0.02
    s_back1 = t1 - 0.02
    s_back0 = s_back1 - step_s
    foot_yaw = ctx.feet_yaw(yaw, front)
    ctx.feet.move(front, s_out0, s_out0 + step_s, home + ahead * fwd + out * right, foot_yaw,
                  lift_m=float(rng.uniform(0.03, 0.10)))  # fmt: skip
    ctx.feet.move(front, s_back0, s_back1, home, foot_yaw, lift_m=float(rng.uniform(0.03, 0.10)))
    onto = _phase_s(dur, 0.3, 0.6, rng, 0.2)
    w = _env(ch.t, s_out0 + 0.5 * step_s, s_back0 + 0.3 * step_s, onto, onto)
    ch.pelvis[:, 1] += float(rng.uniform(0.1, 0.3)) * ahead * w  # past the feet's midpoint
    ch.pelvis[:, 2] -= float(rng.uniform(0.03, 0.10)) * (body.thigh_m + body.shin_m) * w
    ch.trunk_pitch += math.radians(_between(k, 10.0, 30.0)) * w
    ch.load += SIDE_SIGN[front] * 0.3 * w  # the weight goes onto the front foot
    side = 1 if rng.random() < 0.5 else -1
    reach = body.upper_arm_m + 0.99 * body.forearm_m
    hand = (side * 0.08, reach * 0.95, float(rng.uniform(0.0, 0.2)))  # out ahead, at or above the shoulder
    _arm(ctx, side, w, hand, "trunk", (side * 0.6, -0.4, -1.0))


def _bend(ctx: Ctx, seg: Segment, t0: float, t1: float, k: float) -> None:
    ch, rng, body = ctx.ch, ctx.rng, ctx.body
    dur = t1 - t0
    down, up = _phase_s(dur, 0.5, 1.0, rng), _phase_s(dur, 0.5, 1.0, rng)
    w = _env(ch.t, t0, t1, down, up)
    ch.trunk_pitch += math.radians(_between(k, 50.0, 100.0)) * w
    ch.pelvis[:, 2] -= _between(k, 0.03, 0.22) * w  # knees bend more the lower the hands go
    ch.pelvis[:, 1] -= _between(k, 0.05, 0.15) * w
    ch.head_pitch += math.radians(float(rng.uniform(-20.0, 10.0))) * w
    h = body.height_m / 1.75
    spot = (float(rng.uniform(-0.15, 0.15)) * h, float(rng.uniform(0.3, 0.5)) * h, 0.06)
    hands = (-1, 1) if rng.random() < 0.4 else ((1,) if rng.random() < 0.75 else (-1,))
    for side in hands:
        _arm(ctx, side, w, (spot[0] + side * 0.06, spot[1], spot[2]), "body", (side * 1.0, -0.6, 0.0))


def _lean(ctx: Ctx, seg: Segment, t0: float, t1: float, k: float) -> None:
    ch, rng, body = ctx.ch, ctx.rng, ctx.body
    dur = t1 - t0
    down, up = _phase_s(dur, 0.5, 1.0, rng), _phase_s(dur, 0.5, 1.0, rng)
    w = _env(ch.t, t0, t1, down, up)
    angle = math.radians(_between(k, 20.0, 45.0))
    way = str(rng.choice(["forward", "left", "right"], p=[0.4, 0.3, 0.3]))
    shift = _between(k, 0.04, 0.10)
    reach = body.upper_arm_m + 0.99 * body.forearm_m
    if way == "forward":
        ch.trunk_pitch += angle * w
        ch.pelvis[:, 1] -= shift * w
        side = 1 if rng.random() < 0.7 else -1
        _arm(ctx, side, w, (side * 0.1, reach * 0.95, 0.15), "trunk", (side * 0.6, -0.4, -1.0))
        ch.heel += float(rng.uniform(0.0, 0.03)) * k * w[:, None]
    else:
        side = -1 if way == "left" else 1
        ch.trunk_roll += side * angle * w
        ch.pelvis[:, 0] -= side * shift * w
        ch.load += -side * 0.3 * w  # the weight stays over the near foot
        far = LEFT if side < 0 else RIGHT
        ch.heel[:, far] += float(rng.uniform(0.0, 0.03)) * w
        _arm(ctx, side, w, (side * reach * 0.95, 0.1, 0.1), "trunk", (side * 0.4, -0.6, -1.0))


def _tiptoe(ctx: Ctx, seg: Segment, t0: float, t1: float, k: float) -> None:
    ch, rng, body = ctx.ch, ctx.rng, ctx.body
    dur = t1 - t0
    reps = int(rng.integers(1, 4)) if dur > 2.0 else 1
    rise = _between(k, 0.03, 0.08)
    w = np.zeros_like(ch.t)
    slot = dur / reps
    for i in range(reps):
        a = t0 + i * slot
        ramp = _phase_s(slot, 0.2, 0.5, rng)
        w = np.maximum(w, _env(ch.t, a, a + slot, ramp, ramp))
    ch.heel += rise * w[:, None]
    ch.pelvis[:, 2] += rise * w
    if rng.random() < 0.6:  # reaching up for something, looking up
        wr = _env(ch.t, t0, t1, min(0.5, dur / 3), min(0.5, dur / 3))
        reach = body.upper_arm_m + 0.99 * body.forearm_m
        hands = (-1, 1) if rng.random() < 0.4 else (1,)
        for side in hands:
            _arm(ctx, side, wr, (side * 0.08, 0.15, reach * 0.95), "trunk", (side * 1.0, -0.2, 0.0))
        ch.head_pitch -= math.radians(25.0) * wr


def _jump(ctx: Ctx, seg: Segment, t0: float, t1: float, k: float) -> None:
    """Both feet leave and land together; a countermovement before, an absorbed landing after."""
    ch, rng, body = ctx.ch, ctx.rng, ctx.body
    dur = t1 - t0
    flight = _between(k, 0.25, 0.45)
    prep, land = float(rng.uniform(0.3, 0.5)), float(rng.uniform(0.25, 0.4))
    one = prep + flight + land
    n = int(np.clip(rng.integers(1, 4), 1, max(1, int(dur / (one + 0.2)))))
    if n * one > dur:  # too short for even one at this pace: a quicker jump
        prep, flight, land = (x * dur / (n * one) for x in (prep, flight, land))
        one = dur / n
    slot = dur / n
    yaw = ch.yaw_at(t0)
    leg = body.thigh_m + body.shin_m
    h = body.height_m / 1.75
    for i in range(n):
        start = t0 + i * slot + 0.5 * (slot - one)
        off, touch = start + prep, start + prep + flight
        dip = _between(k, 0.08, 0.25) * leg / 0.86
        ch.pelvis[:, 2] -= dip * _env(ch.t, start, off, 0.6 * prep, 0.4 * prep)  # countermovement
        ch.pelvis[:, 2] -= 0.6 * dip * _env(ch.t, touch, touch + land, 0.3 * land, 0.7 * land)  # landing
        up = G * flight**2 / 8.0  # ballistic rise of the body
        inside = (ch.t >= off) & (ch.t < touch)
        s = (ch.t[inside] - off) / flight
        ch.pelvis[inside, 2] += up * 4.0 * s * (1.0 - s)
        push = _env(ch.t, off - 0.12, off + 0.05, 0.1, 0.05)
        ch.heel += 0.06 * push[:, None]
        ch.pelvis[:, 2] += 0.06 * push
        away = ctx.jitter(0.08 * k, yaw)
        tuck = float(rng.uniform(0.0, 0.1))
        for f in (LEFT, RIGHT):
            ctx.feet.move(f, off, touch, ctx.feet.xy[f] + away, lift_m=up + tuck, flight=True)
        ctx.stance_xy = ctx.stance_xy + away
        swing = _env(ch.t, start - 0.2 * prep, touch + 0.5 * land, prep, land)
        for side in (-1, 1):
            _arm(ctx, side, swing, (side * 0.15 * h, 0.25 * h, 0.1 * h), "trunk", (side * 0.6, -0.6, -0.6))


def _sway(ctx: Ctx, seg: Segment, t0: float, t1: float, k: float) -> None:
    ch, rng = ctx.ch, ctx.rng
    w = _env(ch.t, t0, t1, min(1.0, (t1 - t0) / 3), min(1.0, (t1 - t0) / 3))
    f = float(rng.uniform(0.2, 0.6))
    amp = _between(k, 0.02, 0.06)
    ph = float(rng.uniform(0, 2 * np.pi))
    ax = float(rng.uniform(0.3, 1.0))
    ch.pelvis[:, 0] += amp * ax * np.sin(2 * np.pi * f * ch.t + ph) * w
    ch.pelvis[:, 1] += amp * (1 - ax) * np.cos(2 * np.pi * f * ch.t + ph) * w
    ch.trunk_roll -= math.radians(50.0 * amp) * ax * np.sin(2 * np.pi * f * ch.t + ph) * w  # counter-lean


def _dance(ctx: Ctx, seg: Segment, t0: float, t1: float, k: float) -> None:
    ch, rng, body = ctx.ch, ctx.rng, ctx.body
    w = _env(ch.t, t0, t1, min(0.6, (t1 - t0) / 4), min(0.6, (t1 - t0) / 4))
    beat = float(rng.uniform(1.6, 2.4))
    ph = 2 * np.pi * beat * (ch.t - t0)
    bounce = _between(k, 0.01, 0.05)
    ch.pelvis[:, 2] -= bounce * (0.5 - 0.5 * np.cos(ph)) * w
    ch.pelvis[:, 0] += _between(k, 0.02, 0.06) * np.sin(ph / 2) * w
    ch.pelvis_roll += math.radians(4.0) * np.sin(ph / 2) * w
    ch.trunk_twist += math.radians(float(rng.uniform(5.0, 15.0))) * np.sin(ph / 2 + 0.5) * w
    ch.head_pitch += math.radians(6.0) * np.sin(ph) * w
    h = body.height_m / 1.75
    style = rng.random()
    for side in (-1, 1):
        wave = np.sin(ph / 2 + (0.0 if side > 0 else np.pi))
        if style < 0.4:  # arms up, waving
            off = np.stack([side * (0.2 + 0.08 * wave), np.full_like(ch.t, 0.05), 0.3 + 0.1 * wave], -1) * h
        elif style < 0.8:  # elbows bent, pumping
            off = np.stack([side * 0.15 + 0.0 * wave, 0.25 + 0.08 * wave, -0.15 + 0.1 * wave], -1) * h
        else:  # arms out, swaying
            off = np.stack([side * (0.5 + 0.05 * wave), 0.1 + 0.1 * wave, 0.05 * wave], -1) * h
        _arm(ctx, side, w, off, "trunk", (side * 1.0, -0.5, -0.5))


def _weight_shift(ctx: Ctx, seg: Segment, t0: float, t1: float, k: float) -> None:
    ch, rng = ctx.ch, ctx.rng
    dur = t1 - t0
    n = max(1, int(dur / float(rng.uniform(1.2, 3.0))))
    slot = dur / n
    side = float(rng.choice([-1.0, 1.0]))
    for i in range(n):
        a = t0 + i * slot
        ramp = min(0.6, slot / 3)
        w = _env(ch.t, a, a + slot, ramp, ramp)
        amount = _between(k, 0.5, 1.0) * float(rng.uniform(0.8, 1.0))
        ch.load += side * amount * w  # +1: over the right foot
        ch.pelvis_roll += side * math.radians(float(rng.uniform(2.0, 5.0))) * w  # the free hip drops
        free = LEFT if side > 0 else RIGHT
        ch.heel[:, free] += float(rng.uniform(0.0, 0.015)) * w
        side = -side


def _stretch(ctx: Ctx, seg: Segment, t0: float, t1: float, k: float) -> None:
    ch, rng, body = ctx.ch, ctx.rng, ctx.body
    dur = t1 - t0
    ramp = min(0.8, dur / 3)
    w = _env(ch.t, t0, t1, ramp, ramp)
    reach = body.upper_arm_m + 0.99 * body.forearm_m
    kind = str(rng.choice(["overhead", "out", "side", "twist"]))
    if kind == "overhead":
        for side in (-1, 1):
            _arm(ctx, side, w, (side * 0.1, 0.0, reach * 0.97), "trunk", (side * 1.0, 0.0, 0.0))
        ch.trunk_pitch -= math.radians(_between(k, 3.0, 15.0)) * w
        ch.head_pitch -= math.radians(15.0) * w
        if rng.random() < 0.3:
            ch.heel += 0.04 * w[:, None]
            ch.pelvis[:, 2] += 0.04 * w
    elif kind == "out":
        for side in (-1, 1):
            _arm(ctx, side, w, (side * reach * 0.97, 0.05, 0.05), "trunk", (side * 0.0, -1.0, 0.0))
    elif kind == "side":
        side = int(rng.choice([-1, 1]))
        ch.trunk_roll += side * math.radians(_between(k, 15.0, 30.0)) * w
        ch.pelvis[:, 0] -= side * 0.03 * w
        _arm(ctx, -side, w, (side * 0.2, 0.0, reach * 0.95), "trunk", (-side * 1.0, 0.0, 0.0))
    else:
        ch.trunk_twist += float(rng.choice([-1.0, 1.0])) * math.radians(_between(k, 25.0, 50.0)) * w
        for side in (-1, 1):
            _arm(ctx, side, w, (side * reach * 0.9, 0.2, 0.0), "trunk", (side * 0.0, -1.0, 0.0))


LIBRARY: dict[str, Callable[[Ctx, Segment, float, float, float], None]] = {
    "crouch": _crouch,
    "squat": _squat,
    "kneel": _kneel,
    "kneel-forward": functools.partial(_kneel, front_steps=True),
    "step-back": _step_back,
    "lunge": _lunge,
    "bend": _bend,
    "lean": _lean,
    "tiptoe": _tiptoe,
    "jump": _jump,
    "sway": _sway,
    "dance-on-spot": _dance,
    "weight-shift": _weight_shift,
    "stretch": _stretch,
}


def plan_behaviour(ctx: Ctx, seg: Segment, t0: float, t1: float) -> None:
    """Plan a still segment's library behaviour (gestures are :mod:`pipeline.sim.idle`'s)."""
    plan = LIBRARY.get(seg.behaviour_name)
    if plan is None:
        return
    k = float(seg.intensity) if seg.intensity is not None else float(ctx.rng.uniform(0.0, 1.0))
    ctx.ch.busy[ctx.ch.span(t0, t1)] = 1.0
    plan(ctx, seg, t0, t1, k)
