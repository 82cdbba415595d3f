"""Upper body: trunk lean / counter-rotation from the CoM dynamics, pendulum arms, head, gestures."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.blind4.body import Body
from pipeline.sim.blind4.com import PelvisTrack
from pipeline.sim.blind4.feet import FootTracks
from pipeline.sim.blind4.mathutil import (
    FPS,
    GRAVITY,
    apply,
    body_rotation,
    envelope,
    rot_x,
    rot_z,
    smooth,
    smooth_noise,
)
from pipeline.sim.blind4.plan import Plan

FloatArray = NDArray[np.float64]
SIDES = np.array([-1.0, 1.0])  # left arm sits on -x, right arm on +x of the trunk frame
DEG = math.pi / 180.0

# head key points in the head frame (x right, y forward, z up), metres for a 1.75 m person
HEAD_POINTS = np.array(
    [
        [0.0, 0.105, 0.075],  # nose
        [-0.032, 0.085, 0.105],  # l_eye
        [0.032, 0.085, 0.105],  # r_eye
        [-0.075, -0.005, 0.075],  # l_ear
        [0.075, -0.005, 0.075],  # r_ear
    ]
)


@dataclass
class EventSignals:
    """Per-frame contributions of gestures, looks, stretches, bows, poses and turns."""

    trunk_pitch: FloatArray
    trunk_roll: FloatArray
    trunk_yaw: FloatArray
    head_yaw: FloatArray
    head_pitch: FloatArray
    pelvis_back: FloatArray
    pelvis_down: FloatArray
    arm_pose: FloatArray  # (T, 2, 4) envelope-weighted (phi, beta, eps, psi)
    arm_env: FloatArray  # (T, 2) summed envelopes


def _keyframes(n: int, times: list[int], values: list[float]) -> FloatArray:
    """Smooth (cosine-eased) piecewise interpolation through keyframes, constant outside."""
    out = np.full(n, values[0], dtype=np.float64)
    t = np.arange(n)
    for (a, b), (va, vb) in zip(itertools.pairwise(times), itertools.pairwise(values), strict=True):
        if b <= a:
            continue
        m = (t >= a) & (t < b)
        s = (t[m] - a) / (b - a)
        out[m] = va + (vb - va) * (0.5 - 0.5 * np.cos(math.pi * s))
    out[t >= times[-1]] = values[-1]
    return out


def _pose_preset(kind: int, side: float, rng: np.random.Generator) -> tuple[float, float, float, float]:
    """Static idle / bout arm poses (phi, beta, eps, psi) in radians."""
    if kind == 0:  # hands on hips
        return (
            -rng.uniform(0, 15) * DEG,
            rng.uniform(30, 45) * DEG,
            rng.uniform(90, 115) * DEG,
            -side * 90 * DEG,
        )
    if kind == 1:  # arms crossed
        return (
            rng.uniform(20, 35) * DEG,
            rng.uniform(0, 5) * DEG,
            rng.uniform(110, 130) * DEG,
            -side * rng.uniform(70, 85) * DEG,
        )
    if kind == 2:  # hands clasped behind the back
        return (
            -rng.uniform(15, 25) * DEG,
            5 * DEG,
            rng.uniform(40, 70) * DEG,
            -side * rng.uniform(120, 150) * DEG,
        )
    return (rng.uniform(10, 25) * DEG, 0.0, rng.uniform(80, 100) * DEG, -side * rng.uniform(30, 50) * DEG)


def render_events(plan: Plan, body: Body, rng: np.random.Generator) -> EventSignals:
    """Turn the plan's events into per-frame signals."""
    n = plan.n_frames
    z = lambda: np.zeros(n)  # noqa: E731
    sig = EventSignals(z(), z(), z(), z(), z(), z(), z(), np.zeros((n, 2, 4)), np.zeros((n, 2)))
    t = np.arange(n) / FPS
    for ev in plan.events:
        length = max(ev.end - ev.start, 1)
        rise_s = {"stretch": 1.2, "gesture": 0.6, "bow": 0.8, "pose": 0.6}.get(ev.kind, 0.45)
        env = envelope(n, ev.start, ev.end, min(int(rise_s * FPS), length // 3))
        p = ev.params
        erng = np.random.default_rng(int(p.get("seed", rng.integers(1 << 30))))
        arms: list[int] = []
        pose = np.zeros((n, 4))
        if ev.kind == "gesture":
            a = int(p["arm"])
            side = SIDES[a]
            arms = [a]
            kind = int(p["type"])
            if kind == 0:  # wave: forearm up, oscillating in the frontal plane
                f, amp = erng.uniform(1.5, 3.0), erng.uniform(20, 35) * DEG
                pose[:] = [
                    erng.uniform(10, 35) * DEG,
                    erng.uniform(70, 95) * DEG,
                    95 * DEG,
                    side * erng.uniform(75, 95) * DEG,
                ]
                pose[:, 2] += amp * np.sin(2 * math.pi * f * (t - ev.start / FPS))
                sig.trunk_roll -= side * 3 * DEG * env
            elif kind == 1:  # point
                beta = erng.uniform(-10, 45) * DEG
                pose[:] = [erng.uniform(70, 100) * DEG, beta, erng.uniform(3, 15) * DEG, 0.0]
                sig.trunk_yaw += -side * max(beta, 0.0) * 0.3 * env
                sig.head_yaw += -side * max(beta, 0.0) * 0.6 * env
            else:  # reach
                phi = erng.uniform(50, 110) * DEG
                pose[:] = [phi, erng.uniform(0, 25) * DEG, erng.uniform(10, 40) * DEG, 0.0]
                if phi < 80 * DEG:
                    sig.trunk_pitch += erng.uniform(3, 15) * DEG * env
        elif ev.kind == "look-around":
            s0, s1 = ev.start, ev.end
            prof = _keyframes(
                n,
                [s0, s0 + int(0.3 * length), s0 + int(0.45 * length), s0 + int(0.75 * length), s1],
                [0.0, p["yaw1"], p["yaw1"], p["yaw2"], 0.0],
            )
            sig.head_yaw += 0.8 * prof
            sig.trunk_yaw += 0.2 * prof
            sig.head_pitch += p["pitch"] * env
        elif ev.kind == "stretch":
            arms = [0, 1]
            kind = int(p["type"])
            if kind == 2:  # arms out to the sides
                pose[:] = [
                    erng.uniform(0, 20) * DEG,
                    erng.uniform(80, 95) * DEG,
                    erng.uniform(0, 10) * DEG,
                    0.0,
                ]
                sig.trunk_pitch -= 3 * DEG * env
            else:  # overhead, optionally bending sideways
                pose[:] = [
                    erng.uniform(150, 172) * DEG,
                    erng.uniform(0, 20) * DEG,
                    erng.uniform(5, 25) * DEG,
                    0.0,
                ]
                sig.trunk_pitch -= erng.uniform(3, 8) * DEG * env
                sig.head_pitch -= erng.uniform(5, 15) * DEG * env
                if kind == 1:
                    sig.trunk_roll += p["roll"] * env
        elif ev.kind == "bow":
            sig.trunk_pitch += p["pitch"] * env
            sig.head_pitch += p["head"] * env
            sig.pelvis_back += 0.4 * body.trunk * np.sin(p["pitch"] * env)
            sig.pelvis_down += 0.02 * env
        elif ev.kind == "pose":
            arms = [0, 1]
        elif ev.kind == "turn":
            lead = _keyframes(
                n, [ev.start - 6, ev.start + length // 3, ev.end + 6], [0.0, 0.3 * p["angle"], 0.0]
            )
            sig.head_yaw += np.clip(lead, -40 * DEG, 40 * DEG)
        for a in arms:
            if ev.kind == "pose":
                pose[:] = _pose_preset(int(p["type"]), SIDES[a], erng)
            elif ev.kind == "stretch":
                pose[:, 3] = 0.0
            sig.arm_pose[:, a] += env[:, None] * pose
            sig.arm_env[:, a] += env
    return sig


@dataclass
class UpperBody:
    """Upper-body joints (T, ., 3)."""

    shoulders: FloatArray
    elbows: FloatArray
    wrists: FloatArray
    head: FloatArray  # nose, l_eye, r_eye, l_ear, r_ear


def _arm_dynamics(
    phi_cmd: FloatArray,
    beta_cmd: FloatArray,
    acc_f: FloatArray,
    acc_r: FloatArray,
    omega: float,
    zeta: float,
    lc: float,
) -> tuple[FloatArray, FloatArray]:
    """Damped pendulum arms (flexion and abduction per arm) driven by shoulder accelerations."""
    n = phi_cmd.shape[0]
    sub = 4
    dt = 1.0 / (FPS * sub)
    cmd = np.concatenate([phi_cmd, beta_cmd], axis=1)  # (T, 4)
    drive = np.concatenate([-acc_f / lc, -SIDES * acc_r / lc], axis=1)
    x = cmd[0].copy()
    v = np.zeros(4)
    out = np.empty((n, 4))
    w2, c = omega * omega, 2.0 * zeta * omega
    for i in range(n):
        ci, di = cmd[i], drive[i]
        for _ in range(sub):
            v += dt * (w2 * (ci - x) - c * v + di)
            x += dt * v
        out[i] = x
    return out[:, :2], out[:, 2:]


def _soft_limit(x: FloatArray, lo: float, hi: float, margin: float) -> FloatArray:
    """Identity inside [lo+margin, hi-margin], exponential (C1) approach to lo / hi outside."""
    a, b = lo + margin, hi - margin
    above = b + margin * (1.0 - np.exp(-(x - b) / margin))
    below = a - margin * (1.0 - np.exp(-(a - x) / margin))
    return np.where(x > b, above, np.where(x < a, below, x))


def _arm_points(
    shoulder: FloatArray, rot: FloatArray, ang: FloatArray, side: float, body: Body
) -> tuple[FloatArray, FloatArray]:
    """Elbow and wrist from (phi, beta, eps, psi) expressed in the trunk frame."""
    phi, beta, eps, psi = ang[:, 0], ang[:, 1], ang[:, 2], ang[:, 3]
    u = np.stack([side * np.sin(beta), np.sin(phi) * np.cos(beta), -np.cos(phi) * np.cos(beta)], -1)
    w = np.stack([np.zeros_like(phi), np.cos(phi), np.sin(phi)], -1)
    w2 = w * np.cos(psi)[:, None] + np.cross(u, w) * np.sin(psi)[:, None]
    f = u * np.cos(eps)[:, None] + w2 * np.sin(eps)[:, None]
    elbow = shoulder + body.upper_arm * apply(rot, u)
    wrist = elbow + body.forearm * apply(rot, f)
    return elbow, wrist


def upper_body(
    plan: Plan, body: Body, feet: FootTracks, pelvis: PelvisTrack, sig: EventSignals, rng: np.random.Generator
) -> UpperBody:
    """Trunk, head and arms for the whole sequence."""
    n = plan.n_frames
    fwd_h = np.stack([-np.sin(pelvis.heading), np.cos(pelvis.heading)], -1)
    right_h = np.stack([np.cos(pelvis.heading), np.sin(pelvis.heading)], -1)
    acc_com = smooth(pelvis.com_acc, 4.0)  # the trunk's own inertia low-passes the pendulum acceleration
    a_fwd = (acc_com * fwd_h).sum(-1)
    a_lat = (acc_com * right_h).sum(-1)

    # trunk: static lean + inertial lean against the CoM acceleration + counter-rotation
    k_lat, k_ap = rng.uniform(0.5, 1.5), rng.uniform(0.2, 0.8)
    base_pitch = rng.uniform(1.0, 7.0) * DEG
    dyn_pitch = np.clip(-k_ap * a_fwd / GRAVITY, -5 * DEG, 5 * DEG)
    pitch = base_pitch + dyn_pitch + sig.trunk_pitch + smooth_noise(rng, n, 30.0, 0.8 * DEG)
    roll = (
        np.clip(-k_lat * a_lat / GRAVITY, -10 * DEG, 10 * DEG)
        + sig.trunk_roll
        + smooth_noise(rng, n, 30.0, 0.8 * DEG)
    )
    pelvis_osc = pelvis.yaw - pelvis.heading
    counter = rng.uniform(0.8, 1.6)
    yaw_rel = -counter * smooth(pelvis_osc, 2.0) + sig.trunk_yaw + smooth_noise(rng, n, 30.0, 1.5 * DEG)
    rot_t = body_rotation(pelvis.yaw + yaw_rel, roll, pitch)
    neck = pelvis.pos + apply(rot_t, np.array([0.0, -0.01, body.trunk]))
    shoulders = np.stack(
        [neck + apply(rot_t, np.array([s * body.shoulder_half, 0.0, 0.0])) for s in SIDES], 1
    )

    # head: stabilises gaze against trunk oscillations, plus looks
    trunk_world_osc = pelvis.yaw + yaw_rel - pelvis.heading
    head_yaw = -0.7 * (trunk_world_osc - sig.trunk_yaw) + sig.head_yaw + smooth_noise(rng, n, 20.0, 3 * DEG)
    head_pitch = (
        rng.uniform(-5, 10) * DEG
        - 0.6 * (pitch - sig.trunk_pitch - base_pitch)
        + sig.head_pitch
        + smooth_noise(rng, n, 20.0, 2 * DEG)
    )
    rot_h = rot_t @ rot_z(head_yaw) @ rot_x(-head_pitch)
    head_base = neck + apply(rot_t, np.array([0.0, 0.0, body.neck]))
    head = np.stack([head_base + apply(rot_h, HEAD_POINTS[j] * body.head_scale) for j in range(5)], 1)

    # arms: pendulums in the trunk frame, hanging with gravity and driven by the legs / trunk
    acc = smooth(np.gradient(np.gradient(shoulders, axis=0), axis=0) * FPS * FPS, 1.5)
    acc_f = np.einsum("tsi,ti->ts", acc, rot_t[:, :, 1])
    acc_r = np.einsum("tsi,ti->ts", acc, rot_t[:, :, 0])
    rest_phi = rng.uniform(-3, 8, size=2) * DEG
    rest_beta = rng.uniform(4, 12, size=2) * DEG
    swing_amp = smooth(plan.arm_swing, 8.0)
    abduct = smooth(plan.arm_abduct, 8.0)
    lift = smooth(feet.lift, 2.0)
    swing = np.stack([lift[:, 1] - lift[:, 0], lift[:, 0] - lift[:, 1]], 1) * swing_amp[:, None]
    phi_cmd = rest_phi + pitch[:, None] + swing
    beta_cmd = rest_beta + SIDES * roll[:, None] + abduct[:, None] * smooth(lift.sum(1), 3.0)[:, None]
    lc = 0.5 * (body.upper_arm + body.forearm)
    phi, beta = _arm_dynamics(
        phi_cmd, beta_cmd, acc_f, acc_r, 2 * math.pi * rng.uniform(0.8, 1.3), rng.uniform(0.25, 0.5), lc
    )
    eps_rest = rng.uniform(8, 25, size=2) * DEG
    k_e = rng.uniform(0.3, 1.0)
    eps = eps_rest + k_e * np.maximum(phi - rest_phi - pitch[:, None], 0.0)
    psi = np.broadcast_to(-SIDES * rng.uniform(5, 20, size=2) * DEG, (n, 2))
    dyn = np.stack(
        [
            _soft_limit(phi, -60 * DEG, 120 * DEG, 15 * DEG),
            _soft_limit(beta, -12 * DEG, 90 * DEG, 10 * DEG),
            eps,
            psi,
        ],
        -1,
    )
    e = np.minimum(sig.arm_env, 1.0)[..., None]
    norm = np.maximum(sig.arm_env, 1.0)[..., None]
    ang = dyn * (1.0 - e) + sig.arm_pose / norm
    elbows = np.empty((n, 2, 3))
    wrists = np.empty((n, 2, 3))
    for a in range(2):
        elbows[:, a], wrists[:, a] = _arm_points(shoulders[:, a], rot_t, ang[:, a], SIDES[a], body)
    return UpperBody(shoulders=shoulders, elbows=elbows, wrists=wrists, head=head)
