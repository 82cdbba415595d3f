"""From a script to 17 COCO joints: feet first, then pelvis, legs by two-link IK, upper body by FK.

The feet are the ground truth: a planted ankle does not move at all, a swinging one follows its
:class:`~pipeline.sim.blind.script.Move`. The pelvis follows the load: it is pulled over the
supporting foot (smoothed with a zero-phase Gaussian, so the shift starts before the lift-off as an
anticipatory postural adjustment does), dips after each touch-down, and is kept low enough that both
legs reach their ankles. Knees come from analytic two-link inverse kinematics (thigh and shank
exact), bending towards where the foot points. Trunk, head and arms are forward kinematics from the
posture angles; arm flexion is measured from the trunk, so arms keep hanging when the trunk bends.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.blind.body import Body, Style
from pipeline.sim.blind.script import LEFT, RIGHT, Script
from pipeline.sim.blind.timing import (
    FloatArray,
    gaussian_smooth,
    progress,
    smooth_noise,
    soft_min,
    swing_height,
)
from pipeline.skeleton import NUM_JOINTS, J

REACH = 0.9995  # legs never stretch beyond this fraction of thigh + shank


@dataclass(frozen=True, slots=True)
class FootTracks:
    """ankle_m: (T, 2, 3) ankles [left, right]; yaw_deg: (T, 2) where each foot points;
    contact: (T, 2) bool; height: (T, 2) the swing's normalised height (0 planted, 1 at the top);
    march_height: (T, 2) the same for marching steps only (what the arms and pelvis swing with)."""

    ankle_m: FloatArray
    yaw_deg: FloatArray
    contact: NDArray[np.bool_]
    height: FloatArray
    march_height: FloatArray


@dataclass(frozen=True, slots=True)
class Kinematics:
    """The clean skeleton and what the generator knows about it (all per frame).

    joints_m: (T, 17, 3) COCO joints, metres, CAVE frame. contact: (T, 2) bool [left, right].
    yaw_deg: (T,) the person's facing (from the feet, before the pelvis' gait oscillation).
    pelvis_m: (T, 3) the hips' midpoint.
    """

    joints_m: FloatArray
    contact: NDArray[np.bool_]
    yaw_deg: FloatArray
    pelvis_m: FloatArray


def foot_tracks(script: Script, ankle_height_m: float) -> FootTracks:
    """Ankle positions, foot yaws, contacts and swing heights from the script's moves."""
    n = script.n_frames
    ankle = np.zeros((n, 2, 3))
    yaw = np.zeros((n, 2))
    contact = np.ones((n, 2), dtype=bool)
    height = np.zeros((n, 2))
    march_height = np.zeros((n, 2))
    for f in (LEFT, RIGHT):
        ankle[:, f, :2] = script.feet0_xy[f]
        yaw[:, f] = script.yaw0_deg
    ankle[:, :, 2] = ankle_height_m
    tagged = sorted(
        ((m, b.tag) for b in script.bouts for m in b.moves), key=lambda mt: (mt[0].off_f, mt[0].foot)
    )
    for m, tag in tagged:
        if not np.allclose(ankle[m.off_f, m.foot, :2], m.start_xy, atol=1e-9):
            raise RuntimeError(f"move of foot {m.foot} at frame {m.off_f} does not start where the foot is")
        k = np.arange(m.off_f + 1, min(m.on_f, n))
        tau = (k - m.off_f) / (m.on_f - m.off_f)
        h = swing_height(m.law, tau, m.peak_frac, m.hold_frac)
        d = m.delay_frac
        s = progress(m.law, (tau - d) / (1.0 - 2.0 * d))
        dyaw = (m.end_yaw_deg - m.start_yaw_deg + 180.0) % 360.0 - 180.0
        yaw_k = m.start_yaw_deg + s * dyaw
        fwd = np.stack([-np.sin(np.radians(yaw_k)), np.cos(np.radians(yaw_k))], axis=1)
        start, end = np.asarray(m.start_xy), np.asarray(m.end_xy)
        ankle[k, m.foot, :2] = start + s[:, None] * (end - start) + (m.fore_aft_m * h)[:, None] * fwd
        ankle[k, m.foot, 2] = ankle_height_m + m.lift_m * h
        yaw[k, m.foot] = yaw_k
        contact[k, m.foot] = False
        height[k, m.foot] = h
        if tag == "march":
            march_height[k, m.foot] = h
        ankle[m.on_f :, m.foot, :2] = end
        ankle[m.on_f :, m.foot, 2] = ankle_height_m
        yaw[m.on_f :, m.foot] = m.start_yaw_deg + dyaw
    return FootTracks(ankle, yaw, contact, height, march_height)


def _basis(yaw_deg: FloatArray, pitch_deg: FloatArray, roll_deg: FloatArray) -> tuple[FloatArray, ...]:
    """(right, forward, up) unit vectors (T, 3): yaw about +Z, then pitch forward, then roll right."""
    y, p, q = (np.radians(a) for a in (yaw_deg, pitch_deg, roll_deg))
    zero = np.zeros_like(y)
    r0 = np.stack([np.cos(y), np.sin(y), zero], axis=1)
    f0 = np.stack([-np.sin(y), np.cos(y), zero], axis=1)
    z = np.stack([zero, zero, zero + 1.0], axis=1)
    u1 = np.cos(p)[:, None] * z + np.sin(p)[:, None] * f0
    f1 = np.cos(p)[:, None] * f0 - np.sin(p)[:, None] * z
    u2 = np.cos(q)[:, None] * u1 + np.sin(q)[:, None] * r0
    r2 = np.cos(q)[:, None] * r0 - np.sin(q)[:, None] * u1
    return r2, f1, u2


def _turn_basis(
    r: FloatArray, f: FloatArray, u: FloatArray, yaw_deg: FloatArray, pitch_deg: FloatArray
) -> tuple[FloatArray, ...]:
    """A basis turned by yaw about its own up, then pitched (positive: nose down) about its new right."""
    y, p = np.radians(yaw_deg)[:, None], np.radians(pitch_deg)[:, None]
    r1 = np.cos(y) * r + np.sin(y) * f
    f1 = -np.sin(y) * r + np.cos(y) * f
    u2 = np.cos(p) * u + np.sin(p) * f1
    f2 = np.cos(p) * f1 - np.sin(p) * u
    return r1, f2, u2


def two_link(hip: FloatArray, ankle: FloatArray, thigh: float, shank: float, hint: FloatArray) -> FloatArray:
    """Knee positions (T, 3) joining hip and ankle with exact segment lengths, bent towards ``hint``."""
    v = ankle - hip
    d = np.linalg.norm(v, axis=1)
    u = v / d[:, None]
    d = np.clip(d, abs(thigh - shank) + 1e-6, thigh + shank)
    x = (thigh**2 - shank**2 + d**2) / (2.0 * d)
    r = np.sqrt(np.maximum(thigh**2 - x**2, 0.0))
    n = hint - np.sum(hint * u, axis=1)[:, None] * u
    n /= np.linalg.norm(n, axis=1)[:, None]
    return np.asarray(hip + x[:, None] * u + r[:, None] * n, dtype=np.float64)


def _arm(
    shoulder: FloatArray,
    basis: tuple[FloatArray, FloatArray, FloatArray],
    side: float,
    alpha_deg: FloatArray,
    beta_deg: FloatArray,
    elbow_deg: FloatArray,
    rot_deg: FloatArray,
    upper: float,
    fore: float,
) -> tuple[FloatArray, FloatArray]:
    """Elbow and wrist (T, 3) of one arm (side +1 right, −1 left) in the trunk basis (right, fwd, up).

    The hanging arm is flexed forwards by alpha (about the trunk's right axis), then abducted by beta
    (about the trunk's forward axis, away from the body); the forearm bends forwards by the elbow
    angle after the upper arm's external rotation.
    """
    a, b = np.radians(alpha_deg), np.radians(beta_deg)
    e, rho = np.radians(elbow_deg), np.radians(rot_deg)
    d_loc = np.stack([side * np.cos(a) * np.sin(b), np.sin(a), -np.cos(a) * np.cos(b)], axis=1)
    b_loc = np.stack([-side * np.sin(a) * np.sin(b), np.cos(a), np.sin(a) * np.cos(b)], axis=1)
    bend = np.cos(rho)[:, None] * b_loc + side * np.sin(rho)[:, None] * np.cross(d_loc, b_loc)
    fore_loc = np.cos(e)[:, None] * d_loc + np.sin(e)[:, None] * bend
    r, f, u = basis

    def world(v: FloatArray) -> FloatArray:
        return np.asarray(v[:, :1] * r + v[:, 1:2] * f + v[:, 2:] * u, dtype=np.float64)

    elbow = shoulder + upper * world(d_loc)
    wrist = elbow + fore * world(fore_loc)
    return elbow, wrist


def compose(body: Body, style: Style, script: Script, rng: np.random.Generator) -> Kinematics:
    """The clean skeleton of ``script`` performed by ``body`` with ``style``."""
    n, fps = script.n_frames, script.fps
    p = script.posture
    H = body.height_m
    thigh, shank = body.length("thigh_ratio"), body.length("shank_ratio")
    ankle_h = body.length("ankle_ratio")
    feet = foot_tracks(script, ankle_h)
    cl, cr = feet.contact[:, LEFT], feet.contact[:, RIGHT]

    # --- facing: the feet's mean direction, smoothed -----------------------------------------
    yl = np.radians(feet.yaw_deg[:, LEFT])
    yr = np.radians(feet.yaw_deg[:, RIGHT])
    mid = yl + 0.5 * ((yr - yl + np.pi) % (2 * np.pi) - np.pi)
    facing = np.degrees(gaussian_smooth(np.unwrap(mid), 0.12 * fps))
    # marching swings the pelvis, trunk and arms with the legs; side steps and pivots do not
    gait = gaussian_smooth(feet.march_height[:, LEFT] - feet.march_height[:, RIGHT], 0.05 * fps)  # + left up
    stepping = gaussian_smooth(np.maximum(feet.height[:, LEFT], feet.height[:, RIGHT]), 0.1 * fps)
    pelvis_yaw = facing - style.pelvis_rot_deg * gait

    # --- pelvis over the load ----------------------------------------------------------------
    w_r = np.where(cl & cr, 0.5, np.where(cr, 1.0, 0.0))
    w_r = np.clip(w_r + 0.5 * p.weight_bias * (cl & cr), 0.0, 1.0)
    xy_l, xy_r = feet.ankle_m[:, LEFT, :2], feet.ankle_m[:, RIGHT, :2]
    mid_xy = 0.5 * (xy_l + xy_r)
    support = (1.0 - w_r)[:, None] * xy_l + w_r[:, None] * xy_r
    gain = np.where(cl & cr, 0.8, style.sway_gain)  # a deliberate weight shift goes further
    gain = gaussian_smooth(gain, 0.05 * fps)
    target = mid_xy + gain[:, None] * (support - mid_xy)
    pelvis_xy = gaussian_smooth(target, style.sway_sigma_s * fps)
    fwd_p = np.stack([-np.sin(np.radians(facing)), np.cos(np.radians(facing))], axis=1)
    pelvis_xy += (style.fore_offset_m - p.pelvis_back_m)[:, None] * fwd_p
    pelvis_xy += smooth_noise(rng, n, 0.6 * fps, style.sway_m, dims=2)
    load = gaussian_smooth(2.0 * w_r - 1.0, style.sway_sigma_s * fps)  # + loaded on the right

    # --- pelvis height: standing knee bend, touch-down dips, drops, and the legs' reach ---------
    kb = math.radians(style.knee_bend_deg)
    z_stand = ankle_h + math.sqrt(thigh**2 + shank**2 + 2 * thigh * shank * math.cos(kb))
    impulses = np.zeros(n)
    for m in script.moves:
        if m.on_f < n:
            impulses[m.on_f] += 1.0
    sig = 0.08 * fps
    dip = np.minimum(gaussian_smooth(impulses, sig) * sig * math.sqrt(2 * math.pi), 1.5)
    z_des = z_stand - p.pelvis_drop_m - style.bob_m * dip + smooth_noise(rng, n, 0.8 * fps, 0.002)[:, 0]
    obliq = np.radians(
        style.pelvis_obliq_deg * gaussian_smooth(feet.height[:, RIGHT] - feet.height[:, LEFT], 0.05 * fps)
    )  # + right hip up
    half_hip = 0.5 * body.length("hip_width_ratio")
    pr = np.stack([np.cos(np.radians(pelvis_yaw)), np.sin(np.radians(pelvis_yaw))], axis=1)
    hip_side = [-1.0, 1.0]
    limits = []
    for f in (LEFT, RIGHT):
        hip_xy = pelvis_xy + hip_side[f] * half_hip * np.cos(obliq)[:, None] * pr
        dh = np.linalg.norm(hip_xy - feet.ankle_m[:, f, :2], axis=1)
        reach = REACH * (thigh + shank)
        if np.any(dh >= reach):
            raise RuntimeError("a foot is out of the leg's reach; the script asks for an impossible stance")
        vmax = np.sqrt(reach**2 - dh**2)
        limits.append(feet.ankle_m[:, f, 2] + vmax - hip_side[f] * half_hip * np.sin(obliq))
    pelvis_z = soft_min([z_des, *limits], k=0.006)
    pelvis = np.concatenate([pelvis_xy, pelvis_z[:, None]], axis=1)

    # --- hips and legs ------------------------------------------------------------------------
    hip_dir = np.concatenate([np.cos(obliq)[:, None] * pr, np.sin(obliq)[:, None]], axis=1)
    joints = np.zeros((n, NUM_JOINTS, 3))
    for f, (hip_j, knee_j, ankle_j) in zip(
        (LEFT, RIGHT), (("l_hip", "l_knee", "l_ankle"), ("r_hip", "r_knee", "r_ankle")), strict=True
    ):
        hip = pelvis + hip_side[f] * half_hip * hip_dir
        toe = np.radians(feet.yaw_deg[:, f] - hip_side[f] * style.toe_out_deg)
        hint = np.stack([-np.sin(toe), np.cos(toe), np.zeros(n)], axis=1)
        joints[:, J[hip_j]] = hip
        joints[:, J[knee_j]] = two_link(hip, feet.ankle_m[:, f], thigh, shank, hint)
        joints[:, J[ankle_j]] = feet.ankle_m[:, f]

    # --- trunk, head, arms --------------------------------------------------------------------
    trunk_pitch = style.trunk_lean_deg + p.trunk_pitch_deg
    trunk_roll = style.trunk_roll_deg * load + p.trunk_roll_deg
    trunk_yaw = pelvis_yaw + 1.5 * style.pelvis_rot_deg * gait + p.trunk_twist_deg
    tb = _basis(trunk_yaw, trunk_pitch, trunk_roll)
    r_t, f_t, u_t = tb
    neck = pelvis + body.length("trunk_ratio") * u_t
    half_sh = 0.5 * body.length("shoulder_width_ratio")
    joints[:, J["l_shoulder"]] = neck - half_sh * r_t
    joints[:, J["r_shoulder"]] = neck + half_sh * r_t

    r_h, f_h, u_h = _turn_basis(r_t, f_t, u_t, p.head_yaw_deg, style.head_pitch_deg + p.head_pitch_deg)
    up_mid = u_t + u_h
    up_mid /= np.linalg.norm(up_mid, axis=1)[:, None]
    head = neck + body.length("neck_ratio") * up_mid
    s = body.head_ratio * H
    joints[:, J["nose"]] = head + s * (0.055 * f_h - 0.008 * u_h)
    for side, eye, ear in ((-1.0, "l_eye", "l_ear"), (1.0, "r_eye", "r_ear")):
        joints[:, J[eye]] = head + s * (0.040 * f_h + side * 0.017 * r_h + 0.010 * u_h)
        joints[:, J[ear]] = head + s * (side * 0.042 * r_h)

    lag = int(np.rint(style.arm_lag_s * fps))
    swing = style.arm_swing_deg * gait[np.maximum(np.arange(n) - lag, 0)]  # + right arm forward
    upper, fore = body.length("upper_arm_ratio"), body.length("forearm_ratio")
    for arm, side, shoulder_j, elbow_j, wrist_j, sw in (
        (LEFT, -1.0, "l_shoulder", "l_elbow", "l_wrist", -swing),
        (RIGHT, 1.0, "r_shoulder", "r_elbow", "r_wrist", swing),
    ):
        alpha = trunk_pitch + sw + p.arm_alpha_deg[:, arm]  # flexion by the trunk's lean: arms hang
        beta = style.arm_abd_deg + p.arm_beta_deg[:, arm] + 6.0 * stepping  # arms out a little for balance
        elbow_ang = style.elbow_deg + p.elbow_deg[:, arm] + 0.3 * np.abs(sw)
        elbow, wrist = _arm(
            joints[:, J[shoulder_j]],
            (r_t, f_t, u_t),
            side,
            alpha,
            beta,
            elbow_ang,
            p.arm_rot_deg[:, arm],
            upper,
            fore,
        )
        joints[:, J[elbow_j]] = elbow
        joints[:, J[wrist_j]] = wrist

    yaw_wrapped = (facing + 180.0) % 360.0 - 180.0
    return Kinematics(joints, feet.contact.copy(), yaw_wrapped, pelvis)
