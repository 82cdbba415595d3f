"""The simulator's first motion model (before issue 14), frozen: the one ``action.onnx`` was trained on.

The committed recognition model was trained on this generator's motion (MODEL_CARD.md). Its
tests check it on the data it was made for, with :func:`simulate_user_v1`, until the model is
retrained on the widened simulator (:mod:`pipeline.sim.motion`); then this module goes. Nothing
else uses it. Known limits that the new model fixes: planted feet slide with the body while
turning or creeping, motions ramp out after their segment (labels end before the last foot
lands), one stepping pattern per action, bodies 1.50-1.95 m.

The personal style is drawn with the first simulator's ranges (:func:`sample_style_v1`), so a
seed gives the motion it gave then. Contacts are read off the feet (ankle within 1 mm of its
standing height); tags are empty.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.sim.body import (
    FACE_OFFSETS_M,
    REST_ARMS,
    BodyParams,
    MotionStyle,
    apply,
    arm_reach,
    rot_x,
    rot_y,
    rot_z,
    two_bone_ik,
)
from pipeline.sim.motion import STEP_LENGTH_M, UserMotion
from pipeline.sim.script import GESTURES, MotionScript, Segment
from pipeline.sim.signals import smoothstep, wrap_deg
from pipeline.skeleton import NUM_JOINTS, J

F64 = NDArray[np.float64]

_MODES = ("forward", "left", "right", "turn")
MIN_FADE_OUT_S = 0.3
CLASP_BLEND_S = 0.6
_ARM_GESTURES = ("point", "wave", "cross_arms", "hands_on_hips", "touch_face")
_GESTURE_WEIGHTS = np.array([0.25, 0.15, 0.15, 0.1, 0.1, 0.25])  # in GESTURES order


def _bump(s: F64) -> F64:
    """sin^2(pi s) on (0, 1), 0 elsewhere: the lift profile of one step (starts and lands softly)."""
    return np.where((s > 0.0) & (s < 1.0), np.sin(np.pi * np.clip(s, 0.0, 1.0)) ** 2, 0.0)


def _noise(rng: np.random.Generator, t: F64, f_lo: float, f_hi: float, n: int = 3) -> F64:
    """Smooth random signal in [-1, 1]: a few sinusoids of random frequency and phase."""
    f = rng.uniform(f_lo, f_hi, n)
    ph = rng.uniform(0, 2 * np.pi, n)
    a = rng.uniform(0.5, 1.0, n)
    out: F64 = (a[:, None] * np.sin(2 * np.pi * f[:, None] * t[None, :] + ph[:, None])).sum(0) / a.sum()
    return out


def _ramp(active: NDArray[np.bool_], frames_per_blend: F64, min_down_frames: float = 1.0) -> F64:
    """Causal linear ramp towards ``active``, smoothstepped: up at 1/n per frame (n = the
    segment's blend), back down at the same rate but over at least ``min_down_frames``."""
    out = np.zeros(active.shape[0])
    level, down = 0.0, 1.0
    for i, on in enumerate(active.tolist()):
        if on:
            n = max(1.0, float(frames_per_blend[i]))
            down = 1.0 / max(n, min_down_frames)
            level = min(1.0, level + 1.0 / n)
        else:
            level = max(0.0, level - down)
        out[i] = level
    return smoothstep(out)


def _ffill(values: F64, mask: NDArray[np.bool_], initial: float) -> F64:
    """Per frame: ``values`` at the latest frame where ``mask`` holds (``initial`` before any)."""
    idx = np.where(mask, np.arange(mask.shape[0]), -1)
    idx = np.maximum.accumulate(idx)
    return np.where(idx >= 0, values[np.maximum(idx, 0)], initial)


def _window(t: F64, t0: float, t1: float, ramp_s: float) -> F64:
    return smoothstep((t - t0) / ramp_s) * smoothstep((t1 - t) / ramp_s)


def sample_style_v1(rng: np.random.Generator) -> MotionStyle:
    """A personal style drawn as the first simulator drew it (same ranges, same order of draws)."""
    u = rng.uniform
    return MotionStyle(
        cadence_steps_per_s=float(u(1.3, 2.2)),
        knee_lift_m=float(u(0.07, 0.2)),
        lift_asymmetry=float(u(0.85, 1.15)),
        step_variation=float(u(0.04, 0.18)),
        swing_fraction=float(u(0.55, 0.85)),
        arm_swing_deg=float(u(6.0, 35.0)),
        elbow_flex_deg=float(u(5.0, 35.0)),
        rest_arms=str(rng.choice(REST_ARMS, p=[0.8, 0.2])),
        sway_m=float(u(0.004, 0.018)),
        stance_width_m=float(u(0.12, 0.28)),
        trunk_lean_deg=float(u(-2.0, 8.0)),
        head_forward_m=float(u(0.0, 0.05)),
        gesture_rate_hz=float(u(0.03, 0.25)),
        look_deg=float(u(8.0, 45.0)),
        side_step_m=float(u(0.12, 0.32)),
        side_trail_frac=float(u(0.0, 0.6)),
        side_shift_frac=float(u(0.2, 0.5)),
        march_drift_mps=float(u(0.0, 0.03)),
        toe_out_deg=float(u(0.0, 15.0)),
        blend_s=float(u(0.1, 0.4)),
        cadence_drift=float(u(0.0, 0.06)),
        forward_ankle_frac=float(u(0.2, 0.7)),
        knee_flex_deg=float(u(4.0, 14.0)),
    )


@dataclass(frozen=True, slots=True)
class _Gesture:
    kind: str
    side: float  # -1 left arm, +1 right arm
    t0: float
    t1: float
    a: float  # kind-specific random parameters
    b: float


def _schedule_gestures(
    rng: np.random.Generator, segments: tuple[Segment, ...], starts: F64, style: MotionStyle
) -> list[_Gesture]:
    events: list[_Gesture] = []

    def make(kind: str, t0: float, t1: float) -> _Gesture:
        side = 1.0 if rng.random() < 0.8 else -1.0
        if kind == "point":
            a, b = rng.uniform(0.0, np.radians(50)), rng.uniform(np.radians(-15), np.radians(30))
        elif kind == "wave":
            a, b = rng.uniform(1.5, 3.0), 0.0
        elif kind == "look_around":
            a = rng.choice([-1.0, 1.0]) * rng.uniform(np.radians(40), np.radians(85))
            b = rng.uniform(0.2, 0.6)
        else:
            a, b = 0.0, 0.0
        return _Gesture(kind, side, t0, t1, float(a), float(b))

    for seg, start in zip(segments, starts.tolist(), strict=True):
        if seg.action != "still":
            continue
        end = start + seg.duration_s
        if seg.gestures is not None:
            n = len(seg.gestures)
            slot = seg.duration_s / max(n, 1)
            for i, kind in enumerate(seg.gestures):
                dur = min(slot * 0.85, float(rng.uniform(1.5, 4.0)))
                c = start + (i + 0.5) * slot
                events.append(make(kind, c - dur / 2, c + dur / 2))
            continue
        if style.gesture_rate_hz <= 0:
            continue
        cursor = start + float(rng.exponential(1.0 / style.gesture_rate_hz)) * 0.5
        while True:
            dur = float(rng.uniform(1.5, 4.5))
            if cursor + dur > end - 0.2:
                break
            kind = str(rng.choice(GESTURES, p=_GESTURE_WEIGHTS))
            events.append(make(kind, cursor, cursor + dur))
            cursor += dur + float(rng.exponential(1.0 / style.gesture_rate_hz))
    return events


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


def simulate_user_v1(
    script: MotionScript,
    body: BodyParams,
    fps: float = 30.0,
    seed: int = 0,
    style: MotionStyle | None = None,
) -> UserMotion:
    """Animate ``body`` through ``script`` at ``fps``; ``style`` None = drawn from ``seed``."""
    if not isinstance(script, MotionScript):
        raise InputError(f"script must be a MotionScript, got {type(script).__name__}")
    if not np.isfinite(fps) or not 1.0 <= fps <= 1000.0:
        raise InputError(f"fps must be in [1, 1000], got {fps}")
    r_style, r_seg, r_noise, r_evt = (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(4))
    style = style if style is not None else sample_style_v1(r_style)
    segs = script.segments
    n_frames = max(1, round(script.duration_s * fps))
    t = np.arange(n_frames) / fps
    dur = np.array([s.duration_s for s in segs])
    ends = np.cumsum(dur)
    starts = ends - dur
    k = np.minimum(np.searchsorted(ends, t + 1e-9, side="right"), len(segs) - 1)
    action = np.array([s.action for s in segs])[k]
    labels = tuple(segs[i].label for i in k.tolist())

    # Per-segment parameters: the script's values, else the user's own with a little variation.
    def own(value: float | None, default: float, lo: float, hi: float) -> float:
        if value is not None:
            return float(value)
        return float(np.clip(default * r_seg.uniform(0.9, 1.1), lo, hi))

    cad_k = np.array(
        [
            own(
                s.cadence_steps_per_s,
                style.cadence_steps_per_s * (0.8 if s.action == "turn" else 1.0),
                1.0,
                2.6,
            )
            for s in segs
        ]
    )
    lift_k = np.array(
        [
            own(s.knee_lift_m, style.knee_lift_m * (1.0 if s.action == "forward" else 0.7), 0.04, 0.25)
            if s.action != "turn"
            else own(s.knee_lift_m, 0.04, 0.02, 0.08)
            for s in segs
        ]
    )
    width_k = np.array([own(s.step_width_m, style.side_step_m, 0.08, 0.4) for s in segs])
    blend_k = np.array([own(s.blend_s, style.blend_s, 0.05, 0.5) for s in segs])
    travel_k = np.array([s.travel_mps for s in segs])
    turn_k = np.array([s.yaw_change_deg for s in segs])

    # Facing direction and ground-truth yaw.
    yaw_start = script.start_yaw_deg + np.concatenate([[0.0], np.cumsum(turn_k)[:-1]])
    frac = np.clip((t - starts[k]) / dur[k], 0.0, 1.0)
    yaw_unwrapped = yaw_start[k] + turn_k[k] * smoothstep(frac)
    yaw_rad = np.radians(yaw_unwrapped)

    # Motion amplitudes with causal blends.
    blend_frames = blend_k[k] * fps
    # a step under way is finished, not cut: motions fade out over at least MIN_FADE_OUT_S
    amp = {m: _ramp(action == m, blend_frames, MIN_FADE_OUT_S * fps) for m in _MODES}
    a_f, a_l, a_r, a_t = amp["forward"], amp["left"], amp["right"], amp["turn"]
    a_side = a_l + a_r
    a_move = np.clip(a_f + a_side + a_t, 0.0, 1.0)
    a_still = 1.0 - a_move
    moving_seg = action != "still"

    # Cadence (held through the ramp-out) with slow drift; gait phase in cycles (1 cycle = 2 steps).
    cad = _ffill(cad_k[k], moving_seg, style.cadence_steps_per_s)
    cad = cad * (1.0 + style.cadence_drift * _noise(r_noise, t, 0.02, 0.1))
    moving = a_move > 0.0
    phi = np.zeros(n_frames)
    p = 0.0
    for i in range(n_frames):
        if moving[i]:
            if i == 0 or not moving[i - 1]:
                start_right = action[i] == "forward" and r_seg.random() < 0.5
                p = float(np.ceil(p)) + (0.5 if start_right else 0.0)
            p += cad[i] / (2.0 * fps)
        phi[i] = p
    h = np.mod(phi, 1.0)
    step_mult = np.clip(1.0 + style.step_variation * r_noise.standard_normal(int(2 * phi[-1]) + 3), 0.6, 1.4)
    mult = step_mult[np.floor(2 * phi).astype(int)]
    sf = style.swing_fraction
    prof_l = np.where(h < 0.5, _bump(h / (0.5 * sf)), 0.0)
    prof_r = np.where(h >= 0.5, _bump((h - 0.5) / (0.5 * sf)), 0.0)
    sin_g = np.sin(2 * np.pi * phi)
    asym_l, asym_r = style.lift_asymmetry, 1.0 / style.lift_asymmetry

    # Feet: offsets from the standing ankle positions (x right, y forward, z lift), per side.
    lift = {-1: np.zeros(n_frames), 1: np.zeros(n_frames)}
    dx = {-1: np.zeros(n_frames), 1: np.zeros(n_frames)}
    dy = {-1: np.zeros(n_frames), 1: np.zeros(n_frames)}
    # forward: marching (and walking for travelling bystanders)
    lift_f = _ffill(lift_k[k], action == "forward", style.knee_lift_m) * mult * a_f
    lift[-1] += lift_f * asym_l * prof_l
    lift[1] += lift_f * asym_r * prof_r
    travel = _ffill(travel_k[k], action == "forward", 0.0)
    stride = travel / np.maximum(cad, 0.5)
    for side, hs in ((-1, h), (1, np.mod(h + 0.5, 1.0))):
        swing_pos = -0.5 + smoothstep(hs / (0.5 * sf))
        stance_pos = 0.5 - (hs - 0.5) / 0.5
        dy[side] += a_f * stride * np.where(hs < 0.5, swing_pos, stance_pos)
        dy[side] += style.forward_ankle_frac * lift[side]
    # left / right: the leading foot steps out (first half-cycle) and back (second half-cycle)
    hh = np.mod(h, 0.5)
    s_half = hh / (0.5 * sf)
    out = np.where(h < 0.5, smoothstep(s_half), 1.0 - smoothstep(s_half))
    prof_lead = _bump(s_half)
    prof_trail = _bump((hh - 0.5 * sf) / max(0.5 * (1.0 - sf), 1e-6)) if sf < 1.0 else np.zeros(n_frames)
    lift_s = _ffill(lift_k[k], (action == "left") | (action == "right"), style.knee_lift_m * 0.7)
    width_s = _ffill(width_k[k], (action == "left") | (action == "right"), style.side_step_m)
    side_shift = np.zeros(n_frames)
    follow = 0.5 - 0.5 * np.cos(2 * np.pi * h)  # the pelvis follows smoothly, most when the foot is out
    for sign, a_dir in ((-1, a_l), (1, a_r)):
        lift[sign] += a_dir * lift_s * mult * prof_lead
        lift[-sign] += a_dir * lift_s * style.side_trail_frac * prof_trail
        dx[sign] += sign * a_dir * width_s * out
        side_shift += sign * a_dir * follow
    # turning on the spot: small alternating lifts
    lift_t = _ffill(lift_k[k], action == "turn", 0.04) * mult * a_t
    lift[-1] += lift_t * prof_l
    lift[1] += lift_t * prof_r

    # Still behaviours (faded out while moving).
    sway_x = style.sway_m * _noise(r_noise, t, 0.1, 0.4)
    sway_y = style.sway_m * _noise(r_noise, t, 0.1, 0.4)
    ws = _weight_shifts(r_noise, t) * a_still
    dip = _dips(r_noise, t) * a_still
    gestures = _schedule_gestures(r_evt, segs, starts, style)
    head_yaw = np.radians(style.look_deg) * _noise(r_noise, t, 0.03, 0.2) * (0.4 + 0.6 * a_still)
    head_pitch = np.radians(8.0) * _noise(r_noise, t, 0.05, 0.3) + np.radians(4.0) * a_move

    # Pelvis.
    px = sway_x + 0.035 * ws + 0.02 * a_f * sin_g + width_s * style.side_shift_frac * side_shift
    py = sway_y - 0.01 * dip / 0.07
    flex0 = np.radians(style.knee_flex_deg)
    leg_drop = (
        body.thigh_m
        + body.shin_m
        - np.sqrt(body.thigh_m**2 + body.shin_m**2 + 2 * body.thigh_m * body.shin_m * np.cos(flex0))
    )
    pz = body.hip_height_m - leg_drop - dip - 0.005 * a_f * (1 - np.cos(4 * np.pi * phi))
    pelvis = np.stack([px, py, pz], -1)
    pelvis_twist = -np.radians(4.0) * a_f * sin_g
    pelvis_roll = -np.radians(2.5) * ws
    r_pelvis = rot_z(pelvis_twist) @ rot_y(pelvis_roll)
    hips = {c: pelvis + apply(r_pelvis, np.array([c * body.hip_width_m / 2, 0.0, 0.0])) for c in (-1, 1)}

    # Legs: ankles at their targets, knees by IK bending forward (slightly outward).
    toe = np.radians(style.toe_out_deg)
    ankles, knees = {}, {}
    for c in (-1, 1):
        base = np.array([c * style.stance_width_m / 2, 0.0, body.ankle_height_m])
        target = base + np.stack([dx[c], dy[c], lift[c]], -1)
        pole = np.broadcast_to(np.array([c * np.sin(toe), np.cos(toe), 0.0]), target.shape)
        knees[c], ankles[c] = two_bone_ik(hips[c], target, body.thigh_m, body.shin_m, pole)

    # Trunk, shoulders and head.
    twist = 0.25 * head_yaw * a_still + np.radians(style.arm_swing_deg) / 4 * a_f * sin_g
    lean = np.radians(style.trunk_lean_deg) + np.radians(2.0) * a_f + np.radians(10.0) * dip / 0.07
    roll = np.radians(3.0) * side_shift - 0.5 * pelvis_roll
    r_trunk = rot_z(twist) @ rot_x(-lean) @ rot_y(roll)
    neck = pelvis + apply(r_trunk, np.array([0.0, 0.0, body.torso_m]))
    shoulders = {
        c: pelvis + apply(r_trunk, np.array([c * body.shoulder_width_m / 2, 0.0, body.torso_m]))
        for c in (-1, 1)
    }
    g_look = np.zeros(n_frames)
    for g in gestures:
        if g.kind == "look_around":
            w = _window(t, g.t0, g.t1, min(0.6, (g.t1 - g.t0) / 3)) * a_still
            head_yaw = head_yaw + w * g.a * (1.0 - g.b + g.b * np.sin(2 * np.pi * 0.3 * (t - g.t0)))
            g_look += w
        elif g.kind == "point":
            w = _window(t, g.t0, g.t1, min(0.5, (g.t1 - g.t0) / 3)) * a_still
            head_yaw = head_yaw - 0.7 * w * g.side * g.a
    head_center = neck + apply(r_trunk, np.array([0.0, style.head_forward_m, body.neck_m]))
    r_head = rot_z(twist + head_yaw) @ rot_x(-head_pitch)
    face = head_center[:, None, :] + np.einsum("nij,kj->nki", r_head, FACE_OFFSETS_M * body.head_scale)

    # Arms: rest / swing targets blended with gesture targets, elbows by IK.
    ua, fa = body.upper_arm_m, body.forearm_m
    elbows, wrists = {}, {}
    for c in (-1, 1):
        s = shoulders[c]
        swing = c * np.radians(style.arm_swing_deg) * a_f * sin_g
        abduct = np.radians(6.0) + np.radians(14.0) * np.clip(c * side_shift, 0.0, None)
        direction = np.stack(
            [
                c * np.sin(abduct) * np.ones(n_frames),
                np.sin(swing) * np.cos(abduct),
                -np.cos(swing) * np.cos(abduct),
            ],
            -1,
        )
        flex = np.radians(style.elbow_flex_deg) + 0.5 * np.clip(swing, 0.0, None)
        direction = apply(r_trunk, direction)
        target = s + direction * arm_reach(ua, fa, flex)[:, None]
        pole = np.broadcast_to(np.array([c * 0.4, -1.0, 0.0]), target.shape).copy()
        if style.rest_arms == "clasped":
            clasp = pelvis + apply(r_trunk, np.array([c * 0.035, 0.17, -0.03]))
            w_c = _ramp(action == "still", np.full(n_frames, CLASP_BLEND_S * fps))[:, None]
            target = (1 - w_c) * target + w_c * clasp
            pole = (1 - w_c) * pole + w_c * np.array([c * 1.0, -0.5, -0.2])
        for g in gestures:
            if g.kind not in _ARM_GESTURES or (g.kind in ("point", "wave", "touch_face") and g.side != c):
                continue
            w = (_window(t, g.t0, g.t1, min(0.5, (g.t1 - g.t0) / 3)) * a_still)[:, None]
            if g.kind == "point":
                d = np.array([c * np.sin(g.a) * np.cos(g.b), np.cos(g.a) * np.cos(g.b), np.sin(g.b)])
                g_target = s + apply(r_trunk, d) * arm_reach(ua, fa, np.radians(5.0))
                g_pole = np.array([c * 0.6, -0.4, -1.0])
            elif g.kind == "wave":
                wobble = 0.07 * np.sin(2 * np.pi * g.a * (t - g.t0))
                off = np.stack([c * (0.22 + wobble), np.full(n_frames, 0.08), np.full(n_frames, 0.33)], -1)
                g_target = s + apply(r_trunk, off * body.height_m / 1.75)
                g_pole = np.array([c * 1.0, -0.6, -0.6])
            elif g.kind == "cross_arms":
                off = np.array(
                    [
                        -c * (body.shoulder_width_m / 2 - 0.04) - c * body.shoulder_width_m / 2,
                        0.16 if c < 0 else 0.2,
                        -0.27 if c < 0 else -0.23,
                    ]
                )
                g_target = s + apply(r_trunk, off)
                g_pole = np.array([c * 1.0, 0.2, -1.0])
            elif g.kind == "hands_on_hips":
                g_target = hips[c] + apply(r_pelvis, np.array([c * 0.07, -0.02, 0.06]))
                g_pole = np.array([c * 1.0, -0.6, 0.0])
            else:  # touch_face
                g_target = head_center + apply(r_head, np.array([c * 0.02, 0.11, -0.1]))
                g_pole = np.array([c * 0.5, 0.0, -1.0])
            target = (1 - w) * target + w * g_target
            pole = (1 - w) * pole + w * g_pole
        elbows[c], wrists[c] = two_bone_ik(s, target, ua, fa, pole)

    local = np.empty((n_frames, NUM_JOINTS, 3))
    local[:, : FACE_OFFSETS_M.shape[0]] = face
    for c, lr in ((-1, "l"), (1, "r")):
        local[:, J[f"{lr}_shoulder"]] = shoulders[c]
        local[:, J[f"{lr}_elbow"]] = elbows[c]
        local[:, J[f"{lr}_wrist"]] = wrists[c]
        local[:, J[f"{lr}_hip"]] = hips[c]
        local[:, J[f"{lr}_knee"]] = knees[c]
        local[:, J[f"{lr}_ankle"]] = ankles[c]

    # Place in the CAVE: rotate by yaw, move along the (slowly drifting / travelling) root path.
    vy = a_f * (style.march_drift_mps + travel)
    vx = (a_r - a_l) * style.march_drift_mps * 0.5
    c_y, s_y = np.cos(yaw_rad), np.sin(yaw_rad)
    vel = np.stack([c_y * vx - s_y * vy, s_y * vx + c_y * vy], -1)
    root = np.asarray(script.start_xy_m) + np.cumsum(vel, axis=0) / fps
    joints = np.einsum("nij,nkj->nki", rot_z(yaw_rad), local)
    joints[..., :2] += root[:, None, :]

    label_arr = np.array(labels)
    step_len = np.array([STEP_LENGTH_M.get(lb, 0.0) for lb in labels])
    speed = np.where(label_arr == "still", 0.0, step_len * cad)
    speed = np.where((label_arr == "forward") & (travel > 0), np.maximum(speed, travel), speed)
    ankle_z = joints[:, [J["l_ankle"], J["r_ankle"]], 2]
    return UserMotion(
        joints_m=joints,
        labels=labels,
        yaw_deg=wrap_deg(yaw_unwrapped),
        speed_mps=speed,
        fps=float(fps),
        root_xy_m=root,
        tags=("",) * n_frames,
        contacts=ankle_z < body.ankle_height_m + 1e-3,
    )
