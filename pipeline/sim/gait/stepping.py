"""Stepping behaviours: marching in place, side steps, walking and running forward.

Every behaviour appends frames to a :class:`~pipeline.sim.gait.track.Track`, starts from
and returns to the track's last pose with both feet down, and labels its bout from the
first lift-off (or slide start) to the last touch-down (TEAM.md LABELS).

- Marching in place: no normative table exists for it, so the swing leg takes the shape
  of the swing phase of the walking curves (knee flexion peaking a little before the
  thigh, as in Winter's swing), scaled so the knee rises by the asked lift (the thigh
  angle follows from ``lift = thigh (1 - cos theta)``); the foot leaves heel first and
  lands flat or toe first; the weight shifts over the stance foot (hip ab/adduction)
  and the pelvis hikes on the swing side; the arms swing against the legs.
- Side steps: the moving leg abducts (the angle that puts the foot the asked width out,
  ``offset = leg sin(phi)``) while hip and knee flex to lift it; the weight shifts by
  ab/adduction of both hips, which keeps both planted feet in place.
- Walking and running: the Fourier curves of :mod:`pipeline.sim.gait.curves`, the two legs
  half a cycle apart, amplitudes ramped in over the first and out over the last step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.sim.gait.anthropometry import Body
from pipeline.sim.gait.curves import GaitCurves, running, walking
from pipeline.sim.gait.kinematics import Ch
from pipeline.sim.gait.track import DEG, F64, Track, bump, flat_ankle, min_jerk, ramp

SIDE_NAMES = ("left", "right")


def _leg(ch: Ch, side: int) -> int:
    return int(ch) + side


def thigh_for_knee_lift(body: Body, lift_m: float) -> float:
    """Thigh angle (rad) that raises the knee by ``lift_m``."""
    return float(np.arccos(np.clip(1.0 - lift_m / body.thigh_m, -1.0, 1.0)))


def abduction_for_offset(body: Body, offset_m: F64 | float) -> F64:
    """Hip abduction (rad) that puts the ankle ``offset_m`` outward of the hip."""
    return np.asarray(np.arcsin(np.clip(np.asarray(offset_m) / body.leg_m, -0.9, 0.9)))


@dataclass(frozen=True, slots=True)
class MarchParams:
    cadence: float  # steps per second
    knee_lift_m: float
    steps: int
    lead: int  # 0 = left foot first
    swing_share: float  # of a step period
    knee_extra: float  # rad: knee flexion beyond the thigh angle (shank behind the vertical)
    arm_swing: float  # rad, shoulder flexion amplitude
    asymmetry: float  # the weaker side lifts (1 - asymmetry) as high
    irregularity: float  # relative spread of step timing and lift
    pause_prob: float  # chance of a pause after a step
    sway_m: float  # lateral weight shift over the stance foot
    hike: float  # rad, pelvic hike of the swing side
    toe_off: float  # rad, foot pitch at lift-off (negative: heel first)
    land_pitch: float  # rad, foot pitch at touch-down (negative: toe first)

    def __post_init__(self) -> None:
        if not 0.2 <= self.cadence <= 4.0:
            raise ValueError(f"march cadence must be 0.2..4 steps/s, got {self.cadence}")
        if not 0.0 < self.knee_lift_m < 0.6:
            raise ValueError(f"knee lift must be in (0, 0.6) m, got {self.knee_lift_m}")
        if self.steps < 1:
            raise ValueError(f"a march needs at least one step, got {self.steps}")


def march(track: Track, body: Body, p: MarchParams, rng: np.random.Generator) -> None:
    """A marching bout in place, labelled ``forward``, tagged ``march``."""
    base = track.last
    first = len(track)
    weak = int(rng.integers(2))
    for i in range(p.steps):
        side = p.lead if i % 2 == 0 else 1 - p.lead
        stance = 1 - side
        period = max(0.25, (1.0 / p.cadence) * (1.0 + p.irregularity * rng.normal() * 0.5))
        swing_s = float(np.clip(p.swing_share * period, 0.16, 0.95))
        ds_s = max(period - swing_s, 1.0 / track.fps * 2)
        if rng.random() < p.pause_prob:
            ds_s += rng.uniform(0.2, 1.0)
        lift = p.knee_lift_m * (1 - p.asymmetry if side == weak else 1.0)
        lift *= float(np.clip(1.0 + p.irregularity * rng.normal(), 0.5, 1.5))
        lift = float(np.clip(lift, 0.01, 0.8 * body.thigh_m))
        n_pre = max(2, track.frames(min(0.35 * ds_s, 0.25)))
        n_sw = max(3, track.frames(swing_s))
        n_post = max(2, track.frames(ds_s) - n_pre)
        n = n_pre + n_sw + n_post
        a = np.repeat(base[None], n, 0)
        sw = slice(n_pre, n_pre + n_sw)
        theta = thigh_for_knee_lift(body, lift)
        b = bump(n_sw, peak=0.5)
        bk = bump(n_sw, peak=0.42)
        a[sw, _leg(Ch.HIP_FLEX_L, side)] += theta * b
        a[sw, _leg(Ch.KNEE_L, side)] += (theta + p.knee_extra * min(1.0, lift / 0.1)) * bk
        pitch = np.zeros(n)
        pitch[:n_pre] = p.toe_off * ramp(n_pre)
        s = (np.arange(n_sw) + 0.5) / n_sw
        pitch[sw] = p.toe_off + (p.land_pitch - p.toe_off) * min_jerk(s) - 6 * DEG * b
        n_land = min(n_post, track.frames(0.12))
        pitch[n_pre + n_sw : n_pre + n_sw + n_land] = p.land_pitch * (1 - ramp(n_land))
        a[:, _leg(Ch.ANKLE_L, side)] = flat_ankle(
            a[:, _leg(Ch.HIP_FLEX_L, side)], a[:, _leg(Ch.KNEE_L, side)], pitch
        )
        load = 4 * DEG * bump(n_sw, peak=0.3)  # over by touch-down, so the foot lands where it left
        a[sw, _leg(Ch.KNEE_L, stance)] += load
        a[sw, _leg(Ch.HIP_FLEX_L, stance)] += 0.4 * load
        a[:, _leg(Ch.ANKLE_L, stance)] = flat_ankle(
            a[:, _leg(Ch.HIP_FLEX_L, stance)], a[:, _leg(Ch.KNEE_L, stance)]
        )
        # Weight over the stance foot: stance hip adducts, swing hip abducts by the same angle.
        shift = np.concatenate([ramp(n_pre), np.ones(n_sw), 1 - ramp(n_post)])
        phi = float(abduction_for_offset(body, p.sway_m)) * shift
        a[:, _leg(Ch.HIP_ABD_L, stance)] -= phi
        a[:, _leg(Ch.HIP_ABD_L, side)] += phi
        sign = 1.0 if side == 1 else -1.0  # obliquity > 0 drops the right side
        a[:, Ch.PELVIS_OBLIQUITY] -= sign * p.hike * shift
        arm = np.zeros(n)
        arm[sw] = p.arm_swing * b
        a[:, _leg(Ch.SHOULDER_FLEX_L, stance)] += arm
        a[:, _leg(Ch.SHOULDER_FLEX_L, side)] -= 0.6 * arm
        a[:, _leg(Ch.ELBOW_L, stance)] += 0.5 * arm
        a[:, Ch.TRUNK_TWIST] += sign * 0.15 * arm
        contact = np.ones((n, 2), bool)
        contact[sw, side] = False
        track.add(a, contact, home=True)
    track.label_bout(first, "forward", "march")


@dataclass(frozen=True, slots=True)
class SideParams:
    direction: int  # 0 = to the person's left, 1 = right
    kind: str  # side-step-out-back | step-together | step-touch | shuffle
    width_m: float
    cycles: int
    swing_s: float
    dwell_s: float  # double support between the moves
    lift_m: float
    sway_m: float
    weight_share: float  # out-back: how far the weight moves onto the outer foot (0..0.5)
    pause_prob: float
    touch_pitch: float  # rad, the tapping foot's pitch in a step-touch (toe down)

    def __post_init__(self) -> None:
        kinds = ("side-step-out-back", "step-together", "step-touch", "shuffle")
        if self.kind not in kinds:
            raise ValueError(f"side-step kind must be one of {kinds}, got {self.kind!r}")
        if not 0.03 <= self.width_m <= 0.7:
            raise ValueError(f"side-step width must be 0.03..0.7 m, got {self.width_m}")
        if self.cycles < 1:
            raise ValueError(f"a side-step bout needs a cycle, got {self.cycles}")


class _Lateral:
    """Side-step frames from lateral foot offsets: ``e`` the pelvis shift towards the moving
    side, ``d[s]`` each foot's travel towards the moving side (metres, per frame)."""

    def __init__(self, track: Track, body: Body, base: F64, moving: int) -> None:
        self.track, self.body, self.base, self.moving = track, body, base, moving
        self.e = 0.0
        self.d = [0.0, 0.0]
        self.pitch = [0.0, 0.0]
        self.rest = [float(body.leg_m * np.sin(base[Ch.HIP_ABD_L + s])) for s in (0, 1)]

    def block(
        self,
        seconds: float,
        e_to: float | None = None,
        move: int | None = None,
        d_to: float = 0.0,
        lift: float = 0.0,
        contact: tuple[bool, bool] = (True, True),
        slide: tuple[bool, bool] = (False, False),
        pitch_to: float = 0.0,
    ) -> None:
        n = self.track.frames(seconds)
        s = ramp(n)
        e = self.e + ((e_to if e_to is not None else self.e) - self.e) * s
        a = np.repeat(self.base[None], n, 0)
        for side in (0, 1):
            d = np.full(n, self.d[side])
            pitch = np.full(n, self.pitch[side])
            if move == side:
                d = self.d[side] + (d_to - self.d[side]) * s
                pitch = self.pitch[side] + (pitch_to - self.pitch[side]) * s
            # Outward offset of the foot from its hip: towards the moving side is outward for the
            # moving leg and inward for the other.
            out = 1.0 if side == self.moving else -1.0
            offset = self.rest[side] + out * (d - e)
            a[:, Ch.HIP_ABD_L + side] = abduction_for_offset(self.body, offset)
            if move == side and lift > 0:
                theta = np.arccos(np.clip(1 - lift / self.body.leg_m, -1, 1)) * bump(n, 0.5)
                a[:, Ch.HIP_FLEX_L + side] += theta
                a[:, Ch.KNEE_L + side] += 2 * theta
            a[:, Ch.ANKLE_L + side] = flat_ankle(a[:, Ch.HIP_FLEX_L + side], a[:, Ch.KNEE_L + side], pitch)
        sign = 1.0 if self.moving == 1 else -1.0
        a[:, Ch.PELVIS_OBLIQUITY] += sign * 0.25 * (e / self.body.leg_m)
        a[:, Ch.TRUNK_SIDE] -= sign * 0.3 * (e / self.body.leg_m)
        self.track.add(a, contact, slide)
        self.e = float(e[-1])
        if move is not None:
            self.d[move] = d_to
            self.pitch[move] = pitch_to


def side_steps(track: Track, body: Body, p: SideParams, rng: np.random.Generator) -> None:
    """A side-step bout towards ``p.direction``, labelled ``left``/``right``, tagged ``p.kind``."""
    base = track.last
    first = len(track)
    m, st = p.direction, 1 - p.direction
    lat = _Lateral(track, body, base, m)
    shuffle = p.kind == "shuffle"
    together = p.kind == "step-together" or (shuffle and rng.random() < 0.5)
    both = (True, True)
    for c in range(p.cycles):
        lift = 0.0 if shuffle else p.lift_m
        up_m = (m == 0 and not shuffle, m == 1 and not shuffle)
        up = (not up_m[0], not up_m[1])
        sl = (shuffle and m == 0, shuffle and m == 1)
        lat.block(0.15 + 0.1 * rng.random(), e_to=-p.sway_m)
        if p.kind == "step-touch":
            lat.block(p.swing_s, move=m, d_to=p.width_m, lift=lift, contact=up, pitch_to=p.touch_pitch)
            lat.block(rng.uniform(0.08, 0.3), contact=both)
            lat.block(p.swing_s, move=m, d_to=0.0, lift=lift, contact=up, pitch_to=0.0)
        elif together:
            lat.block(p.swing_s, move=m, d_to=p.width_m, lift=lift, contact=up if not shuffle else both,
                      slide=sl)
            lat.block(p.dwell_s, e_to=p.width_m + p.sway_m)
            stl = (shuffle and st == 0, shuffle and st == 1)
            up_st = (st != 0 or shuffle, st != 1 or shuffle)
            lat.block(p.swing_s, move=st, d_to=p.width_m, lift=lift, contact=up_st, slide=stl)
            lat.block(0.1 + 0.1 * rng.random(), e_to=p.width_m)
            lat.e, lat.d = 0.0, [0.0, 0.0]  # both feet and the pelvis moved by the width: re-base
        else:
            lat.block(p.swing_s, move=m, d_to=p.width_m, lift=lift, contact=up if not shuffle else both,
                      slide=sl)
            lat.block(p.dwell_s, e_to=-p.sway_m + p.weight_share * p.width_m)
            lat.block(0.12, e_to=-p.sway_m)
            lat.block(p.swing_s, move=m, d_to=0.0, lift=lift, contact=up if not shuffle else both, slide=sl)
        last = c == p.cycles - 1
        rest = rng.uniform(0.2, 1.0) if (not last and rng.random() < p.pause_prob) else 0.12
        lat.block(rest, e_to=0.0)
    track.label_bout(first, SIDE_NAMES[p.direction], p.kind)


@dataclass(frozen=True, slots=True)
class GaitParams:
    cadence: float  # steps per second at full speed
    scale: float  # amplitude of the thigh and ankle curves (stride length)
    cycles: int  # full strides at full amplitude
    run: bool
    arm_swing: float  # gain
    lead: int

    def __post_init__(self) -> None:
        if not 0.8 <= self.cadence <= 4.0:
            raise ValueError(f"gait cadence must be 0.8..4 steps/s, got {self.cadence}")
        if not 0.2 <= self.scale <= 1.6:
            raise ValueError(f"gait scale must be 0.2..1.6, got {self.scale}")


def _gait_angles(
    base: F64, walk: GaitCurves, run: GaitCurves, phase_r: F64, env: F64, mix: F64, p: GaitParams
) -> tuple[F64, np.ndarray]:
    n = len(phase_r)
    a = np.repeat(base[None], n, 0)
    contact = np.ones((n, 2), bool)
    thighs = []
    for side in (0, 1):
        ph = phase_r + (0.5 if side == 0 else 0.0)
        thigh = (1 - mix) * walk.thigh(ph) + mix * run.thigh(ph)
        knee = (1 - mix) * walk.knee(ph) + mix * run.knee(ph)
        ankle = (1 - mix) * walk.ankle(ph) + mix * run.ankle(ph)
        a[:, Ch.HIP_FLEX_L + side] += env * p.scale * thigh
        a[:, Ch.KNEE_L + side] += env * knee * (0.7 + 0.3 * p.scale)
        a[:, Ch.ANKLE_L + side] += env * p.scale * ankle
        toe_off = (1 - mix) * walk.toe_off + mix * run.toe_off
        contact[:, side] = np.mod(ph, 1.0) < toe_off
        thighs.append(thigh)
    a[:, Ch.PELVIS_OBLIQUITY] -= env * walk.obliquity(phase_r) * p.scale  # > 0 drops the right side
    a[:, Ch.PELVIS_ROTATION] += env * walk.rotation(phase_r) * p.scale  # > 0 brings the right side forward
    a[:, Ch.PELVIS_TILT] += env * walk.tilt(phase_r)
    a[:, Ch.TRUNK_TWIST] -= 0.4 * env * walk.rotation(phase_r) * p.scale
    for side in (0, 1):
        other = thighs[1 - side]
        a[:, Ch.SHOULDER_FLEX_L + side] += env * p.arm_swing * 0.8 * (other - walk.thigh.mean)
        a[:, Ch.ELBOW_L + side] += env * (mix * 75 * DEG + 8 * DEG * (other - walk.thigh.mean) / 0.3)
    a[:, Ch.TRUNK_LEAN] += env * mix * 8 * DEG
    return a, contact


def gait(track: Track, body: Body, p: GaitParams) -> None:
    """Walking (tag ``walk``) or running (tag ``run``) forward along the heading, labelled ``forward``."""
    walk, run = walking(), running()
    base = track.last
    first = len(track)
    f_walk = min(p.cadence, 2.1) / 2  # strides per second while walking in and out
    f_full = p.cadence / 2
    # Start with the leading leg at toe-off, the other just after its loading response.
    lead_phase0 = walk.toe_off - 0.01
    phase0 = lead_phase0 + (0.5 if p.lead == 0 else 0.0)  # phase of the right leg
    ramp_cycles = 1.0
    total = ramp_cycles * 2 + p.cycles
    dt = 1.0 / track.fps
    phases, envs, mixes = [], [], []
    ph, u = phase0, 0.0
    while u < total:
        env = min_jerk(np.array(min(u, total - u) / ramp_cycles))
        mix = float(env) if p.run else 0.0
        e = 0.35 + 0.65 * float(env)
        phases.append(ph)
        envs.append(e)
        mixes.append(mix)
        f = f_walk + (f_full - f_walk) * float(env) if p.run else f_full
        ph += f * dt
        u += f * dt
    phase_r = np.array(phases)
    a, contact = _gait_angles(base, walk, run, phase_r, np.array(envs), np.array(mixes), p)
    # End in double support: cut after the last frame with both feet down.
    end = int(np.flatnonzero(contact.all(axis=1))[-1]) + 1
    a, contact = a[:end], contact[:end]
    # Ease from the resting pose into the first frame and back out of the last (feet down).
    track.ease(a[0], 0.3)
    track.add(a, contact)
    track.ease(base, 0.45)
    track.label_bout(first, "forward", "run" if p.run else "walk")
