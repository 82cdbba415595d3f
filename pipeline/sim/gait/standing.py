"""Standing behaviours, all labelled ``still`` with a tag (TEAM.md LABELS).

Postures are joint-angle targets eased in and out with minimum-jerk profiles, the feet
planted (flat unless the behaviour rises on the toes). Squat and crouch depths follow
the ranges of motion in Hemmerich et al. (2006), "Hip, knee, and ankle kinematics of high
range of motion activities of daily living", *J. Orthop. Res.* 24:770-781 (squat: hip
flexion about 95-120 deg, knee about 130-155 deg, ankle dorsiflexion about 30-40 deg;
kneeling on one knee: the kneeling knee about 90-110 deg).
"""

from __future__ import annotations

import numpy as np

from pipeline.sim.gait.anthropometry import Body
from pipeline.sim.gait.kinematics import Ch, forward
from pipeline.sim.gait.stepping import abduction_for_offset
from pipeline.sim.gait.track import DEG, F64, Track, bump, flat_ankle, ramp


def _legs(row: F64, side: int, hip: float, knee: float, pitch: float = 0.0) -> None:
    row[Ch.HIP_FLEX_L + side] = hip
    row[Ch.KNEE_L + side] = knee
    row[Ch.ANKLE_L + side] = float(flat_ankle(hip, knee, pitch))


def _pose_and_back(
    track: Track, target: F64, rng: np.random.Generator, tag: str, hold_s: float,
    back_tag: str | None = None, down_s: tuple[float, float] = (0.5, 1.2),
) -> None:
    start = track.last
    track.ease(target, rng.uniform(*down_s), tag=tag)
    track.hold(hold_s, tag=tag)
    track.ease(start, rng.uniform(*down_s), tag=back_tag or tag)


def crouch(track: Track, rng: np.random.Generator, deep: bool) -> None:
    """A crouch (tag ``crouch``) or a deep squat (``squat``); rising is tagged ``stand-up``."""
    row = track.last
    hip = rng.uniform(85, 115) * DEG if deep else rng.uniform(25, 65) * DEG
    knee = hip + (rng.uniform(25, 40) if deep else rng.uniform(12, 30)) * DEG
    heels_up = deep and rng.random() < 0.35
    pitch = -rng.uniform(10, 25) * DEG if heels_up else 0.0
    lean = hip * rng.uniform(0.35, 0.6)
    for side in (0, 1):
        _legs(row, side, hip, knee, pitch)
        # Shoulder flexion is relative to the trunk. Deep down, the arms reach forward of the
        # vertical (a counterweight; hanging, the hands would go through the floor).
        arm = lean + rng.uniform(20, 80) * DEG if deep else rng.uniform(0, 80) * DEG
        row[Ch.SHOULDER_FLEX_L + side] = arm
        row[Ch.ELBOW_L + side] = rng.uniform(10, 70) * DEG
    row[Ch.TRUNK_LEAN] = lean
    row[Ch.HEAD_PITCH] = rng.uniform(-20, 25) * DEG
    _pose_and_back(track, row, rng, "squat" if deep else "crouch", rng.uniform(0.4, 3.0), "stand-up")


def bend(track: Track, rng: np.random.Generator) -> None:
    """Bending down to pick something up (tag ``bend``)."""
    row = track.last
    lean = rng.uniform(50, 100) * DEG
    knee = rng.uniform(5, 45) * DEG
    for side in (0, 1):
        _legs(row, side, -rng.uniform(0, 10) * DEG + 0.4 * knee, knee)
        row[Ch.SHOULDER_FLEX_L + side] = lean * rng.uniform(0.8, 1.15)
        row[Ch.ELBOW_L + side] = rng.uniform(0, 30) * DEG
    row[Ch.TRUNK_LEAN] = lean
    row[Ch.HEAD_PITCH] = -rng.uniform(0, 30) * DEG
    _pose_and_back(track, row, rng, "bend", rng.uniform(0.3, 1.5))


def lean(track: Track, body: Body, rng: np.random.Generator) -> None:
    """Leaning far forward, back or sideways from the hips (tag ``lean``)."""
    row = track.last
    kind = rng.integers(3)
    if kind == 0:
        row[Ch.TRUNK_LEAN] = rng.uniform(20, 45) * DEG
        for side in (0, 1):
            _legs(row, side, -rng.uniform(2, 8) * DEG, row[Ch.KNEE_L + side])
    elif kind == 1:
        row[Ch.TRUNK_LEAN] = -rng.uniform(10, 25) * DEG
    else:
        sign = rng.choice([-1.0, 1.0])
        row[Ch.TRUNK_SIDE] = sign * rng.uniform(10, 30) * DEG
        shift = -sign * rng.uniform(0.02, 0.06)  # hips move against the lean
        _shift_pelvis(row, body, track.last, shift)
    row[Ch.SHOULDER_ABD_L] += rng.uniform(0, 30) * DEG
    _pose_and_back(track, row, rng, "lean", rng.uniform(0.5, 3.0))


def _shift_pelvis(row: F64, body: Body, base: F64, shift_m: float) -> None:
    """Hip ab/adduction that moves the pelvis ``shift_m`` to the right over planted feet."""
    for side, out in ((0, 1.0), (1, -1.0)):
        rest = body.leg_m * np.sin(base[Ch.HIP_ABD_L + side])
        row[Ch.HIP_ABD_L + side] = float(abduction_for_offset(body, rest + out * shift_m))


def weight_shift(track: Track, body: Body, rng: np.random.Generator, dance: bool = False) -> None:
    """Shifting the weight from foot to foot (``weight-shift``), or dancing on the spot (``dance``)."""
    base = track.last
    period = rng.uniform(0.6, 1.2) if dance else rng.uniform(1.2, 3.0)
    cycles = int(rng.integers(2, 5))
    n = track.frames(period * cycles)
    t = np.arange(n) / track.fps
    env = np.minimum(1.0, np.minimum(t, t[-1] - t) / 0.4)
    phase = 2 * np.pi * t / period
    shift = rng.uniform(0.02, 0.08) * np.sin(phase) * env
    a = np.repeat(base[None], n, 0)
    heel = rng.random() < 0.5
    for side, out in ((0, 1.0), (1, -1.0)):
        rest = body.leg_m * np.sin(base[Ch.HIP_ABD_L + side])
        a[:, Ch.HIP_ABD_L + side] = abduction_for_offset(body, rest + out * shift)
        # The unloaded foot (the pelvis moved away from it) may lift its heel, the ball planted.
        unload = np.clip(out * shift / 0.05, 0.0, 1.0) if heel else np.zeros(n)
        knee = a[:, Ch.KNEE_L + side] + unload * rng.uniform(8, 20) * DEG
        bounce = (rng.uniform(5, 18) * DEG * (0.5 - 0.5 * np.cos(2 * phase)) * env) if dance else 0.0
        hip = a[:, Ch.HIP_FLEX_L + side] + 0.45 * bounce
        knee = knee + bounce
        a[:, Ch.HIP_FLEX_L + side] = hip
        a[:, Ch.KNEE_L + side] = knee
        a[:, Ch.ANKLE_L + side] = flat_ankle(hip, knee, -unload * rng.uniform(5, 15) * DEG)
        if dance:
            arm = rng.uniform(20, 70) * DEG
            a[:, Ch.SHOULDER_FLEX_L + side] += arm * (0.5 + 0.5 * np.sin(phase + side * np.pi)) * env
            a[:, Ch.ELBOW_L + side] += rng.uniform(20, 80) * DEG * env
    a[:, Ch.TRUNK_SIDE] += -0.5 * shift / body.leg_m
    if dance:
        a[:, Ch.TRUNK_TWIST] += rng.uniform(5, 20) * DEG * np.sin(phase / 2) * env
        a[:, Ch.HEAD_YAW] += rng.uniform(0, 25) * DEG * np.sin(phase / 2 + 1) * env
    track.add(a, tag="dance" if dance else "weight-shift")


def sway(track: Track, body: Body, rng: np.random.Generator) -> None:
    """Swaying about the ankles, forward-back and side to side (tag ``sway``)."""
    base = track.last
    n = track.frames(rng.uniform(2.0, 6.0))
    t = np.arange(n) / track.fps
    env = np.minimum(1.0, np.minimum(t, t[-1] - t) / 0.5)
    ap = rng.uniform(1, 4) * DEG * np.sin(2 * np.pi * rng.uniform(0.2, 0.6) * t) * env
    ml = rng.uniform(0.005, 0.04) * np.sin(2 * np.pi * rng.uniform(0.2, 0.6) * t + rng.uniform(0, 6)) * env
    a = np.repeat(base[None], n, 0)
    for side, out in ((0, 1.0), (1, -1.0)):
        hip = a[:, Ch.HIP_FLEX_L + side] + ap
        a[:, Ch.HIP_FLEX_L + side] = hip
        a[:, Ch.ANKLE_L + side] = flat_ankle(hip, a[:, Ch.KNEE_L + side])
        rest = body.leg_m * np.sin(base[Ch.HIP_ABD_L + side])
        a[:, Ch.HIP_ABD_L + side] = abduction_for_offset(body, rest + out * ml)
    track.add(a, tag="sway")


def tiptoe(track: Track, body: Body, rng: np.random.Generator) -> None:
    """Rising on the toes (tag ``tiptoe``)."""
    row = track.last
    rise = rng.uniform(0.03, 0.08)
    pitch = -float(np.arcsin(rise / (body.heel_back_m + body.ball_forward_m)))
    for side in (0, 1):
        _legs(row, side, row[Ch.HIP_FLEX_L + side], row[Ch.KNEE_L + side], pitch)
    row[Ch.SHOULDER_FLEX_L] += rng.uniform(0, 40) * DEG
    _pose_and_back(track, row, rng, "tiptoe", rng.uniform(0.5, 3.0), down_s=(0.3, 0.8))


def arms(track: Track, rng: np.random.Generator, kind: str) -> None:
    """Gestures: ``wave`` (one or both hands), ``point``, ``stretch``."""
    row = track.last
    start = track.last
    side = int(rng.integers(2))
    sides = (0, 1) if (kind == "stretch" or (kind == "wave" and rng.random() < 0.3)) else (side,)
    for s in sides:
        if kind == "wave":
            row[Ch.SHOULDER_FLEX_L + s] = rng.uniform(90, 160) * DEG
            row[Ch.SHOULDER_ABD_L + s] = rng.uniform(10, 45) * DEG
            row[Ch.ELBOW_L + s] = rng.uniform(20, 70) * DEG
        elif kind == "point":
            row[Ch.SHOULDER_FLEX_L + s] = rng.uniform(60, 110) * DEG
            row[Ch.SHOULDER_ABD_L + s] = rng.uniform(0, 60) * DEG
            row[Ch.ELBOW_L + s] = rng.uniform(0, 15) * DEG
            row[Ch.TRUNK_TWIST] = (1 if s == 0 else -1) * rng.uniform(0, 25) * DEG
            row[Ch.HEAD_YAW] = (1 if s == 0 else -1) * rng.uniform(0, 30) * DEG
        else:
            row[Ch.SHOULDER_FLEX_L + s] = rng.uniform(150, 175) * DEG
            row[Ch.SHOULDER_ABD_L + s] = rng.uniform(0, 20) * DEG
            row[Ch.ELBOW_L + s] = rng.uniform(0, 20) * DEG
    if kind == "stretch":
        row[Ch.TRUNK_LEAN] = -rng.uniform(0, 15) * DEG
        row[Ch.TRUNK_SIDE] = rng.uniform(-20, 20) * DEG
    track.ease(row, rng.uniform(0.4, 0.9), tag=kind)
    n = track.frames(rng.uniform(0.8, 3.0))
    a = np.repeat(row[None], n, 0)
    if kind == "wave":
        freq, amp = rng.uniform(1.5, 3.0), rng.uniform(10, 25) * DEG
        osc = amp * np.sin(2 * np.pi * freq * np.arange(n) / track.fps) * np.minimum(1, np.arange(n) / 5)
        for s in sides:
            a[:, Ch.SHOULDER_ABD_L + s] += osc
            a[:, Ch.ELBOW_L + s] += 0.5 * osc
    track.add(a, tag=kind)
    track.ease(start, rng.uniform(0.4, 0.9), tag=kind)


def look_around(track: Track, rng: np.random.Generator) -> None:
    """Looking around: head and trunk turning, the feet planted (tag ``look-around``)."""
    start = track.last
    for _ in range(int(rng.integers(2, 5))):
        row = start.copy()
        yaw = rng.uniform(-70, 70) * DEG
        row[Ch.HEAD_YAW] = 0.7 * yaw
        row[Ch.TRUNK_TWIST] = 0.3 * yaw
        row[Ch.PELVIS_ROTATION] = 0.1 * yaw
        row[Ch.HEAD_PITCH] = rng.uniform(-25, 25) * DEG
        track.ease(row, rng.uniform(0.4, 1.2), tag="look-around")
        track.hold(rng.uniform(0.2, 1.5), tag="look-around")
    track.ease(start, rng.uniform(0.4, 1.0), tag="look-around")


def step(track: Track, body: Body, side: int, seconds: float, lift_m: float, end: F64,
         tag: str, home: bool = False) -> None:
    """One foot lifted and put down while every channel moves from the last pose to ``end``."""
    start = track.last
    n = track.frames(seconds)
    s = ramp(n)[:, None]
    a = start + (end - start) * s
    theta = float(np.arccos(np.clip(1 - lift_m / body.leg_m, -1, 1))) * bump(n)
    a[:, Ch.HIP_FLEX_L + side] += theta
    a[:, Ch.KNEE_L + side] += 2 * theta
    contact = np.ones((n, 2), bool)
    contact[:, side] = False
    track.add(a, contact, tag=tag, home=home)


def turn(track: Track, body: Body, rng: np.random.Generator, angle: float | None = None) -> None:
    """Turning on the spot with pivot steps (tag ``turn``): ``angle`` rad, counter-clockwise > 0."""
    start = track.last
    total = angle if angle is not None else rng.choice([-1.0, 1.0]) * rng.uniform(30, 180) * DEG
    toe = (start[Ch.FOOT_YAW_L] - start[Ch.FOOT_YAW_R]) / 2
    steps = max(1, int(np.ceil(abs(total) / (rng.uniform(35, 70) * DEG))))
    lead = 0 if total > 0 else 1  # turning left: the left foot opens first
    lift = rng.uniform(0.01, 0.05)
    swing = rng.uniform(0.25, 0.45)
    yaw = start[Ch.YAW]
    for i in range(steps):
        new_yaw = start[Ch.YAW] + total * (i + 1) / steps
        for k, side in enumerate((lead, 1 - lead)):
            end = track.last
            if k == 0:
                end[Ch.YAW] = new_yaw
            end[Ch.FOOT_YAW_L + side] = new_yaw + (toe if side == 0 else -toe)
            step(track, body, side, swing, lift, end, "turn")
            track.hold(rng.uniform(0.0, 0.15), tag="turn")
        yaw = new_yaw
    final = start.copy()
    final[Ch.YAW] = yaw
    final[Ch.FOOT_YAW_L] = yaw + toe
    final[Ch.FOOT_YAW_R] = yaw - toe
    track.ease(final, 0.2, tag="turn")


KNEE_CLEARANCE_M = 0.04  # kneeling: the knee joint centre above the floor (half a knee's depth)


def _knee_clearance(body: Body, row: F64, side: int) -> float:
    """Height of ``side``'s knee centre above the lowest sole point of the pose ``row`` (both
    feet down, so that sole point is on the floor)."""
    rel = forward(body, row[None])
    floor = float(min(rel.heel[0, :, 2].min(), rel.ball[0, :, 2].min()))
    return float(rel.knee[0, side, 2]) - floor


def kneel(track: Track, body: Body, rng: np.random.Generator) -> None:
    """Kneeling on one knee: step back, go down, stay, come up, step in (tag ``kneel``)."""
    start = track.last
    back = int(rng.integers(2))
    front = 1 - back
    stepped = start.copy()
    # The back foot goes about a leg length back, where the kneeling shank will lie.
    _legs(stepped, back, -rng.uniform(40, 50) * DEG, rng.uniform(20, 35) * DEG, -rng.uniform(30, 45) * DEG)
    step(track, body, back, rng.uniform(0.5, 0.8), 0.04, stepped, "kneel")
    down = stepped.copy()
    f_hip = rng.uniform(75, 95) * DEG
    f_extra = rng.uniform(0, 15) * DEG
    _legs(down, back, rng.uniform(-10, 10) * DEG, rng.uniform(90, 110) * DEG, -rng.uniform(45, 70) * DEG)
    # The kneeling knee rests on the floor, its centre a knee's half-thickness above it: open the
    # front leg (which holds the pelvis up) until it is.
    for _ in range(12):
        _legs(down, front, f_hip, f_hip + f_extra)
        if _knee_clearance(body, down, back) >= KNEE_CLEARANCE_M:
            break
        f_hip -= 3 * DEG
        f_extra = max(0.0, f_extra - 2 * DEG)
    down[Ch.TRUNK_LEAN] = rng.uniform(0, 20) * DEG
    down[Ch.SHOULDER_FLEX_L + front] = rng.uniform(0, 40) * DEG
    track.ease(down, rng.uniform(0.8, 1.6), tag="kneel")
    track.hold(rng.uniform(1.0, 6.0), tag="kneel")
    track.ease(stepped, rng.uniform(0.8, 1.6), tag="kneel")
    step(track, body, back, rng.uniform(0.4, 0.7), 0.04, start, "kneel", home=True)


def jump(track: Track, body: Body, rng: np.random.Generator) -> None:
    """Jumping in place, one to three times (tag ``jump``)."""
    start = track.last
    for _ in range(int(rng.integers(1, 4))):
        dip = start.copy()
        hip = rng.uniform(20, 45) * DEG
        for side in (0, 1):
            _legs(dip, side, hip, hip + rng.uniform(25, 40) * DEG)
            dip[Ch.SHOULDER_FLEX_L + side] = -rng.uniform(20, 50) * DEG
        dip[Ch.TRUNK_LEAN] = 0.5 * hip
        track.ease(dip, rng.uniform(0.3, 0.5), tag="jump")
        push = start.copy()
        toe = -rng.uniform(20, 35) * DEG
        for side in (0, 1):
            _legs(push, side, 0.0, 0.0, toe)
            push[Ch.SHOULDER_FLEX_L + side] = rng.uniform(40, 140) * DEG
        track.ease(push, rng.uniform(0.12, 0.2), tag="jump")
        height = rng.uniform(0.05, 0.25)
        n = track.frames(2 * np.sqrt(2 * height / 9.81))
        tuck = bump(n)
        a = np.repeat(push[None], n, 0)
        for side in (0, 1):
            a[:, Ch.HIP_FLEX_L + side] += 20 * DEG * tuck
            a[:, Ch.KNEE_L + side] += 40 * DEG * tuck
            a[:, Ch.ANKLE_L + side] += 20 * DEG * tuck
        track.add(a, (False, False), tag="jump")
        land = start.copy()
        hip = rng.uniform(15, 35) * DEG
        for side in (0, 1):
            _legs(land, side, hip, hip + rng.uniform(20, 40) * DEG)
        land[Ch.TRUNK_LEAN] = 0.4 * hip
        track.ease(land, rng.uniform(0.15, 0.3), tag="jump")
        track.ease(start, rng.uniform(0.3, 0.6), tag="jump")
