"""Stepping bouts and turns on the spot: where and when each foot steps.

Behaviours (the frames' tags) and what the feet do:

- ``march`` (forward): alternating lifts in place, each foot landing back at its home place
  (a little forward when the person creeps or travels); optionally landing ahead and sliding
  back during the stance, or the reverse (``slide_m``); the ankle comes forward (or the heel
  kicks back) as it rises (``bulge``).
- ``walk`` / ``run`` (forward): real travel along the facing direction; the first step starts
  from standing, the last one closes beside the other foot; running has a flight phase (the
  next foot lifts before the last one lands).
- ``side-step-out-back`` (left / right): the foot on that side steps out and back; the other
  foot may tap (a small lift while the weight is out).
- ``step-together``: the leading foot steps out, the trailing foot follows and closes: the
  person travels sideways.
- ``shuffle``: step-together as low slides without a visible lift (a low out-and-back is a
  ``side-step-out-back`` with a small ``knee_lift_m``).
- ``turn`` (still): turning on the spot while the body turns smoothly: either each foot
  re-places itself in a few brief lifts or swivels at irregular moments (no rhythm of steps), or
  (half of the turns) in rhythmic pivot steps, left and right in turn at 1-2.4 steps/s, each
  lifted 2-8 cm and turned 15-45 degrees: a rhythm like marching's, with the body turning.

A bout's first lift-off is its segment's start and its last touch-down the segment's end
(:func:`pipeline.sim.feet.bout_times`), so labels follow TEAM.md's LABELS exactly.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.body import MotionStyle
from pipeline.sim.feet import LEFT, RIGHT, SIDE_SIGN, bout_times, forward_xy, right_xy
from pipeline.sim.plan import Ctx
from pipeline.sim.ranges import RUN_RAMP_S, WALK_RAMP_S
from pipeline.sim.script import PAUSE_RANGE, Segment
from pipeline.sim.signals import smoothstep

F64 = NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Bout:
    """One stepping bout, every parameter resolved (from the script or the person's own style).

    action: forward | left | right. behaviour: from ``script.BEHAVIOURS[action]``.
    t0 / t1: first lift-off and last touch-down, s. cadence: steps/s. swing_frac: air time per
    step period. lift_m: peak ankle rise. width_m: side-step width beyond the home place.
    travel_mps: real travel (march creeping, walking, running). pause_prob / pause_s: pauses
    between steps. irregularity: random spread of timing, lift and placement. asymmetry: left
    lift / right lift. arm_swing_rad: peak arm swing. slide_m: stance slide (+ back, - forward).
    bulge: the ankle's forward detour relative to its lift. trail_lift_m: side steps: lift of the
    other foot's tap (0 = it stays planted).
    weight_shift: how far the pelvis moves over the stance foot during a step.
    lead_load: side steps: how far the weight follows the leading foot out while both are down.
    """

    action: str
    behaviour: str
    t0: float
    t1: float
    cadence: float
    swing_frac: float
    lift_m: float
    width_m: float
    travel_mps: float
    pause_prob: float
    pause_s: tuple[float, float]
    irregularity: float
    asymmetry: float
    arm_swing_rad: float
    slide_m: float
    bulge: float
    trail_lift_m: float
    weight_shift: float
    lead_load: float


def resolve_bout(seg: Segment, t0: float, t1: float, style: MotionStyle, rng: np.random.Generator) -> Bout:
    """A stepping segment's bout: the script's values, else the person's own (a little varied)."""
    u = rng.uniform

    def own(value: float | None, default: float, lo: float, hi: float) -> float:
        if value is not None:
            return float(value)
        return float(np.clip(default * u(0.9, 1.1), lo, hi))

    kind = seg.behaviour_name
    lift_default = style.knee_lift_m * (1.0 if seg.action == "forward" else 0.7)
    if kind == "walk":
        cadence = own(seg.cadence_steps_per_s, 1.0 + 0.75 * seg.travel_mps, 1.2, 2.4)
        swing, lift, bulge = float(u(0.72, 0.86)), own(seg.knee_lift_m, float(u(0.06, 0.14)), 0.03, 0.25), 0.0
    elif kind == "run":
        cadence = own(seg.cadence_steps_per_s, 2.4 + 0.15 * seg.travel_mps, 2.4, 3.3)
        swing, lift, bulge = float(u(1.15, 1.35)), own(seg.knee_lift_m, float(u(0.15, 0.3)), 0.08, 0.4), -0.4
    else:
        cadence = own(seg.cadence_steps_per_s, style.cadence_steps_per_s, 0.5, 2.6)
        swing = style.swing_fraction
        lift = own(seg.knee_lift_m, lift_default, 0.03, 0.3)
        bulge = style.forward_ankle_frac if kind == "march" else 0.1
    if kind == "shuffle":
        swing = max(swing, 0.75)
        lift = min(lift, float(u(0.0, 0.012))) if seg.knee_lift_m is None else min(lift, 0.015)
    travel = seg.travel_mps + (style.march_drift_mps if kind == "march" else 0.0)
    arm = own(seg.arm_swing_deg, style.arm_swing_deg * (1.5 if kind == "run" else 1.0), 0.0, 60.0)
    side_lift = style.side_trail_frac * lift * 0.6
    return Bout(
        action=seg.action,
        behaviour=kind,
        t0=t0,
        t1=t1,
        cadence=cadence,
        swing_frac=swing,
        lift_m=lift,
        width_m=own(seg.step_width_m, style.side_step_m, 0.08, 0.45),
        travel_mps=travel,
        pause_prob=own(seg.pause_prob, style.pause_prob, 0.0, 1.0) if kind not in ("walk", "run") else 0.0,
        pause_s=seg.pause_s if seg.pause_s is not None else PAUSE_RANGE,
        irregularity=own(seg.irregularity, style.step_irregularity, 0.0, 1.0),
        asymmetry=seg.asymmetry if seg.asymmetry is not None else style.lift_asymmetry,
        arm_swing_rad=math.radians(arm),
        slide_m=own(seg.slide_m, style.march_slide_m, -0.15, 0.15) if kind == "march" else 0.0,
        bulge=bulge,
        trail_lift_m=side_lift if kind == "side-step-out-back" and style.side_trail_frac > 0.15 else 0.0,
        weight_shift=(0.3 if kind in ("walk", "run") else style.weight_shift_frac) * min(1.0, 1.6 / cadence),
        lead_load=float(np.clip(1.6 * style.side_shift_frac, 0.0, 0.9)),
    )


def plan_bout(ctx: Ctx, b: Bout) -> float:
    """Plan the feet of one bout and write its channels (arm swing, pelvis smoothing, tags).

    Returns the bout's realised cadence: steps per second from its first to its last lift-off
    (pauses and the fitting into the segment included; the planned cadence for a single step).
    """
    span = ctx.ch.span(b.t0, b.t1)
    ctx.ch.arm_swing[span] = b.arm_swing_rad
    ctx.ch.weight_shift[span] = b.weight_shift
    ctx.ch.tag(b.t0, b.t1, b.behaviour)
    if b.behaviour == "march":
        steps = _march(ctx, b)
    elif b.behaviour in ("walk", "run"):
        steps = _travel(ctx, b)
        ctx.ch.arm_walk[span] = 1.0
    else:
        steps = _side(ctx, b)
    lifts = [t0 for _, t0, _ in steps]
    if len(lifts) < 2 or lifts[-1] - lifts[0] <= 0:
        return b.cadence
    return (len(lifts) - 1) / (lifts[-1] - lifts[0])


def _alternate(first: int) -> Callable[[int], int]:
    return lambda k: (first + k) % 2


def _swing_mult(b: Bout) -> tuple[float, float]:
    """Timing asymmetry that goes with a lift asymmetry: the higher-lifting foot swings longer."""
    a = float(np.clip(b.asymmetry, 0.5, 2.0)) ** 0.15
    return (a, 1.0 / a)


def _lift(ctx: Ctx, b: Bout, foot: int) -> float:
    mult = float(np.clip(1.0 + b.irregularity * ctx.rng.standard_normal(), 0.4, 1.6))
    asym = b.asymmetry if foot == LEFT else 1.0 / b.asymmetry
    return b.lift_m * mult * asym


@dataclass(frozen=True, slots=True)
class _Path:
    """The stance centre travelling along the facing direction: where it is at a time, and where
    it is once it has gone a distance (both clamped to the bout)."""

    t0: float
    grid: F64  # times
    xy: F64  # (G, 2) positions
    dist: F64  # (G,) distance travelled

    def at(self, t: float) -> F64:
        return np.array([np.interp(t, self.grid, self.xy[:, 0]), np.interp(t, self.grid, self.xy[:, 1])])

    def along(self, d: float) -> F64:
        """Where the centre is after ``d`` metres (beyond the end: the end)."""
        return self.at(float(np.interp(d, self.dist, self.grid)))

    def gone(self, t: float) -> float:
        return float(np.interp(t, self.grid, self.dist))

    def speed(self, t: float) -> float:
        i = int(np.clip(np.searchsorted(self.grid, t), 1, len(self.grid) - 1))
        return float((self.dist[i] - self.dist[i - 1]) / (self.grid[i] - self.grid[i - 1]))


def _path(ctx: Ctx, t0: float, t1: float, speed_mps: float, ramp_s: float = 0.0) -> _Path:
    """The stance centre travelling at ``speed_mps`` over [t0, t1], speeding up from standing over
    the first ``ramp_s`` and slowing down over the last ``ramp_s`` seconds (smoothly; at most
    a third of the bout each)."""
    grid = np.linspace(t0, max(t1, t0 + 1e-3), max(2, int((t1 - t0) * 60) + 2))
    dur = grid[-1] - grid[0]
    ramp = min(max(ramp_s, 0.0), dur / 3.0)
    profile = np.ones_like(grid)
    if ramp > 0:
        profile = smoothstep((grid - t0) / ramp) * smoothstep((grid[-1] - grid) / ramp)
    v = speed_mps * profile
    yaw = np.interp(grid, ctx.ch.t, ctx.ch.yaw)
    vel = v[:, None] * np.stack([-np.sin(yaw), np.cos(yaw)], -1)
    dt = np.diff(grid)[:, None]
    cum = np.concatenate([np.zeros((1, 2)), np.cumsum(0.5 * (vel[1:] + vel[:-1]) * dt, axis=0)])
    dist = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt[:, 0])])
    return _Path(t0, grid, ctx.stance_xy + cum, dist)


def _placement_error(ctx: Ctx, b: Bout, yaw: float) -> F64:
    return ctx.jitter(0.004 + 0.03 * b.irregularity, yaw)


Steps = list[tuple[int, float, float]]


def _march(ctx: Ctx, b: Bout) -> Steps:
    rng, ch = ctx.rng, ctx.ch
    steps = bout_times(
        rng,
        b.t0,
        b.t1,
        b.cadence,
        b.swing_frac,
        foot_of=_alternate(int(rng.integers(2))),
        swing_mult=_swing_mult(b),
        pause_prob=b.pause_prob,
        pause_s=b.pause_s,
        irregularity=b.irregularity,
    )
    path = _path(ctx, b.t0, b.t1, b.travel_mps).at
    next_of = {
        k: next((j for j in range(k + 1, len(steps)) if steps[j][0] == f), None)
        for k, (f, _, _) in enumerate(steps)
    }
    for k, (f, t0, t1) in enumerate(steps):
        yaw = ch.yaw_at(t1)
        fwd = forward_xy(yaw)
        nxt = next_of[k]
        glide = b.slide_m != 0.0 and nxt is not None
        target = ctx.home(f, yaw, path(t1)) + _placement_error(ctx, b, yaw)
        if glide:
            target = target + fwd * b.slide_m / 2.0
        lift = _lift(ctx, b, f)
        ctx.feet.move(f, t0, t1, target, ctx.feet_yaw(yaw, f), lift_m=lift, bulge_m=b.bulge * lift)
        if glide and nxt is not None:
            g0, g1 = t1 + 0.03, steps[nxt][1] - 0.03
            if g1 > g0 + 0.05:
                ctx.feet.move(f, g0, g1, target - fwd * b.slide_m, planted=True)
    ctx.stance_xy = path(b.t1)
    return steps


def _tent(t: F64, peak: float, rise_s: float, fall_s: float) -> F64:
    """0 -> 1 over [peak - rise_s, peak] and back to 0 over [peak, peak + fall_s], smoothly."""
    up = smoothstep((t - (peak - rise_s)) / max(rise_s, 1e-6))
    down = smoothstep((peak + fall_s - t) / max(fall_s, 1e-6))
    out: F64 = np.where(t < peak, up, down)
    return out


def _travel(ctx: Ctx, b: Bout) -> Steps:
    """Walking or running: the centre speeds up, travels and slows down along the path; each
    foot lands ahead of it (walking: 0.4 of a step, running: 0.2), the last step closing beside
    the other foot; the trailing heel rises before each lift-off (toe-off)."""
    rng, ch = ctx.rng, ctx.ch
    run = b.behaviour == "run"
    steps = bout_times(
        rng,
        b.t0,
        b.t1,
        b.cadence,
        b.swing_frac,
        foot_of=_alternate(int(rng.integers(2))),
        swing_mult=_swing_mult(b),
        irregularity=b.irregularity,
        flight=run,
    )
    n = len(steps)
    ramp = RUN_RAMP_S if run else WALK_RAMP_S
    path = _path(ctx, b.t0, b.t1, b.travel_mps, ramp_s=ramp)
    leg = ctx.body.thigh_m + ctx.body.shin_m
    reach = (n - 1) * (1.1 if run else 0.75) * leg  # a bout of n steps cannot go further than this
    if path.dist[-1] > reach:
        slower = b.travel_mps * reach / float(path.dist[-1])
        path = _path(ctx, b.t0, b.t1, slower, ramp_s=ramp)
    total = float(path.dist[-1])
    ahead = 0.2 if run else 0.4
    span = ch.span(b.t0, b.t1)
    ch.path_xy[span] = np.stack([path.at(float(t)) for t in ch.t[span]]) if span.any() else ch.path_xy[span]
    ch.path_w[span] = 1.0
    period = 1.0 / b.cadence
    for k, (f, t0, t1) in enumerate(steps):
        landing = path.gone(t1) + ahead * path.speed(t1) / b.cadence
        gone = total if k == n - 1 else min(landing, total)
        centre = path.along(gone)
        yaw = ch.yaw_at(float(np.interp(gone, path.dist, path.grid)))
        target = ctx.home(f, yaw, centre) + _placement_error(ctx, b, yaw)
        lift = _lift(ctx, b, f)
        ctx.feet.move(f, t0, t1, target, ctx.feet_yaw(yaw, f), lift_m=lift, bulge_m=b.bulge * lift)
        pace = float(np.clip(path.speed(t0) / 1.2, 0.3, 1.3))
        heel = float(rng.uniform(0.04, 0.08)) * pace
        ch.heel[:, f] += heel * _tent(ch.t, t0, 0.35 * period, 0.3 * (t1 - t0))
    ch.elbow_flex[span] += math.radians(70.0 if run else 10.0)
    ch.trunk_pitch[span] += math.radians(float(rng.uniform(4.0, 10.0)) if run else 2.0)
    ctx.stance_xy = path.at(b.t1)
    return steps


def _side(ctx: Ctx, b: Bout) -> Steps:
    rng, ch = ctx.rng, ctx.ch
    lead = LEFT if b.action == "left" else RIGHT
    trail = 1 - lead
    sign = SIDE_SIGN[lead]
    out_back = b.behaviour == "side-step-out-back"
    steps = bout_times(
        rng,
        b.t0,
        b.t1,
        b.cadence,
        b.swing_frac,
        foot_of=(lambda k: lead) if out_back else (lambda k: lead if k % 2 == 0 else trail),
        swing_mult=_swing_mult(b),
        pause_prob=b.pause_prob,
        pause_s=b.pause_s,
        irregularity=b.irregularity,
        same_foot=out_back,
        even=True,
    )
    reach = 0.0
    for k, (f, t0, t1) in enumerate(steps):
        yaw = ch.yaw_at(t1)
        r = right_xy(yaw)
        if k % 2 == 0:
            spread = float(np.clip(1.0 + 0.5 * b.irregularity * rng.standard_normal(), 0.6, 1.4))
            reach = min(b.width_m * spread, 0.5)
        # placed from the other foot, so that a stance left wide before cannot add up
        if out_back:
            target = ctx.feet.xy[trail] + sign * (ctx.width_m + (reach if k % 2 == 0 else 0.0)) * r
        elif f == lead:
            target = ctx.feet.xy[trail] + sign * (ctx.width_m + reach) * r
        else:
            target = ctx.feet.xy[lead] - sign * ctx.width_m * r
        target = target + _placement_error(ctx, b, yaw) * 0.5
        lift = _lift(ctx, b, f)
        ctx.feet.move(f, t0, t1, target, ctx.feet_yaw(yaw, f), lift_m=lift, bulge_m=0.1 * lift)
        if k % 2 == 0 and k + 1 < len(steps):  # the weight follows the foot out while it is down
            ctx.ch.load[ctx.ch.span(t1, steps[k + 1][1])] = sign * b.lead_load
        tap_room = steps[k + 1][1] - t1 if k + 1 < len(steps) else 0.0
        if out_back and k % 2 == 0 and b.trail_lift_m > 0.004 and tap_room > 0.25:
            a0 = t1 + 0.06
            a1 = a0 + min(0.35, tap_room - 0.12)
            ctx.feet.move(trail, a0, a1, ctx.feet.xy[trail] + ctx.jitter(0.005, yaw), lift_m=b.trail_lift_m)
    ctx.stance_xy = 0.5 * (ctx.feet.xy[LEFT] + ctx.feet.xy[RIGHT])
    return steps


def pivot_turn(ctx: Ctx, t0: float, t1: float) -> None:
    """Re-place the feet around the stance centre while the body turns over [t0, t1] (yaw channel)."""
    rng, ch = ctx.rng, ctx.ch
    yaw0, yaw1 = ch.yaw_at(t0), ch.yaw_at(t1)
    total = yaw1 - yaw0
    if abs(total) < math.radians(3.0) or t1 - t0 < 0.2:
        return
    if rng.random() < 0.5 and _rhythmic_pivots(ctx, t0, t1, total):
        return
    per_foot = max(1, math.ceil(abs(total) / math.radians(float(rng.uniform(40.0, 75.0)))))
    first = LEFT if total > 0 else RIGHT  # turning left: the left foot opens first
    order = [(first + i) % 2 for i in range(2 * per_foot)]
    for i in range(len(order) - 1):
        if rng.random() < 0.15:
            order[i], order[i + 1] = order[i + 1], order[i]
    dur_total = t1 - t0
    durs = rng.uniform(0.15, 0.35, len(order))
    if durs.sum() > 0.8 * dur_total:
        durs *= 0.8 * dur_total / durs.sum()
    gaps = rng.uniform(0.05, 1.0, len(order) + 1)  # irregular: no rhythm of steps
    gaps[-1] *= 0.3
    gaps *= (dur_total - durs.sum()) / gaps.sum()
    last = {f: max(i for i, g in enumerate(order) if g == f) for f in set(order)}
    t = t0 + gaps[0]
    for i, f in enumerate(order):
        a, b = t, t + durs[i]
        yaw = yaw1 if i == last[f] else ch.yaw_at(b) + float(rng.normal(0.0, math.radians(6.0)))
        target = ctx.home(f, yaw) + ctx.jitter(0.01, yaw)
        swivel = rng.random() < 0.45
        ctx.feet.move(
            f,
            a,
            b,
            target,
            ctx.feet_yaw(yaw, f),
            lift_m=0.0 if swivel else float(rng.uniform(0.01, 0.05)),
            planted=swivel,
        )
        t = b + gaps[i + 1]


def _rhythmic_pivots(ctx: Ctx, t0: float, t1: float, total: float) -> bool:
    """Turn in rhythmic pivot steps (left and right in turn, each lifted and turned 15-45 degrees);
    False (nothing planned) when the turn is too short for two such steps."""
    rng, ch = ctx.rng, ctx.ch
    per_step = math.radians(float(rng.uniform(15.0, 45.0)))
    n = max(2, math.ceil(abs(total) / per_step))
    period = (t1 - t0) / n
    cadence = 1.0 / period
    if cadence > 2.4:  # too fast for this turn: fewer, larger steps
        n = max(2, math.floor((t1 - t0) * 2.4))
        period = (t1 - t0) / n
    if period < 0.3 or n < 2:
        return False
    swing = period * float(rng.uniform(0.5, 0.75))
    lift = float(rng.uniform(0.02, 0.08))
    first = LEFT if total > 0 else RIGHT  # turning left: the left foot opens first
    for i in range(n):
        f = (first + i) % 2
        a = t0 + i * period + float(rng.uniform(0.0, 0.1)) * (period - swing)
        b = a + swing
        yaw = ch.yaw_at(t1) if i >= n - 2 else ch.yaw_at(b)
        target = ctx.home(f, yaw) + ctx.jitter(0.01, yaw)
        ctx.feet.move(f, a, b, target, ctx.feet_yaw(yaw, f), lift_m=lift * float(rng.uniform(0.8, 1.2)))
    return True
