"""Centre of mass and pelvis: ZMP reference over the support feet + linear inverted pendulum."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.blind4.body import Body
from pipeline.sim.blind4.feet import FootTracks
from pipeline.sim.blind4.mathutil import (
    FPS,
    apply,
    body_rotation,
    conservative_smooth,
    fwd_vec,
    lipm_filter,
    right_vec,
    smooth,
    smooth_noise,
    smoothstep,
)
from pipeline.sim.blind4.plan import RIGHT, Plan, Swing

FloatArray = NDArray[np.float64]


@dataclass
class PelvisTrack:
    """Pelvis (mid-hip point) pose and the pendulum quantities that drive the upper body."""

    pos: FloatArray  # (T, 3) mid-hip point
    yaw: FloatArray  # (T,)
    roll: FloatArray  # (T,)
    heading: FloatArray  # (T,) smoothed mean foot heading
    rot: FloatArray  # (T, 3, 3) pelvis orientation
    hips: FloatArray  # (T, 2, 3) left / right hip joints
    com: FloatArray  # (T, 2) horizontal CoM
    com_acc: FloatArray  # (T, 2) horizontal CoM acceleration  omega^2 (x - p)
    zmp: FloatArray  # (T, 2) ZMP reference
    w_ref: FloatArray  # (T,) reference weight fraction on the left foot
    w_com: FloatArray  # (T,) pendulum-filtered weight fraction (drives pelvis roll)


def weight_reference(plan: Plan) -> FloatArray:
    """Fraction of the body weight on the left foot implied by the swings and still behaviours.

    In a swing the whole weight is on the other foot; between close swings the weight
    transfers smoothly during double support; far from any swing it relaxes to the
    still-behaviour baseline ``plan.w_base`` (0.5 = even stance, weight shifts, sways).
    """
    n = plan.n_frames
    base = plan.w_base
    w = base.copy()
    swings = sorted(plan.swings, key=lambda s: s.lo)
    tr_max = round(0.4 * FPS)

    def val(s: Swing) -> float:
        return 1.0 if s.foot == RIGHT else 0.0

    for sw in swings:
        w[sw.lo : min(sw.td, n)] = val(sw)
    prev: Swing | None = None
    seq: list[Swing | None] = [*swings, None]
    for s in seq:
        if prev is None and s is None:
            break
        if prev is not None and s is not None and s.lo - prev.td <= int(0.7 * FPS):
            g0, g1 = prev.td, s.lo
            gap = max(g1 - g0, 1)
            v0, v1 = val(prev), val(s)
            vmid = 0.5 if prev.foot == s.foot else 0.5 * (v0 + v1)
            vmid = v0 + (vmid - v0) * min(1.0, gap / 10.0)  # a quick re-step barely unloads the stance foot
            k = np.arange(g0, min(g1, n))
            x = (k - g0 + 0.5) / gap
            w[k] = np.where(
                x < 0.5, v0 + (vmid - v0) * smoothstep(2 * x), vmid + (v1 - vmid) * smoothstep(2 * x - 1)
            )
        else:
            if prev is not None:
                g0 = prev.td
                g1 = n if s is None else s.lo
                tr = max(min(tr_max, (g1 - g0) // 2), 1)
                k = np.arange(g0, min(g0 + tr, n))
                w[k] = val(prev) + (base[k] - val(prev)) * smoothstep((k - g0 + 0.5) / tr)
            if s is not None:
                g0 = 0 if prev is None else prev.td
                tr = max(min(tr_max, (s.lo - g0) // 2), 1)
                k = np.arange(max(s.lo - tr, 0), s.lo)
                w[k] = base[k] + (val(s) - base[k]) * smoothstep((k - (s.lo - tr) + 0.5) / tr)
        prev = s
    return w


def pelvis_motion(
    plan: Plan,
    feet: FootTracks,
    body: Body,
    rng: np.random.Generator,
    pelvis_back: FloatArray,
    pelvis_down: FloatArray,
) -> PelvisTrack:
    """Pelvis trajectory from the LIPM CoM, with step-synchronous bob, roll and yaw."""
    n = plan.n_frames
    heading = smooth(feet.yaw.mean(axis=1), 4.0)
    fwd, right = fwd_vec(heading), right_vec(heading)
    w = weight_reference(plan)
    ap = 0.03 + plan.zmp_ap + smooth_noise(rng, n, 25.0, 0.004)
    lat_noise = smooth_noise(rng, n, 30.0, 0.005)
    zmp = (
        w[:, None] * feet.pos[:, 0]
        + (1.0 - w[:, None]) * feet.pos[:, 1]
        + ap[:, None] * fwd
        + lat_noise[:, None] * right
    )
    omega = body.omega
    com = lipm_filter(zmp, omega)
    com_acc = omega**2 * (com - zmp)
    w_com = lipm_filter(w, omega)

    xy = com - (0.03 + pelvis_back)[:, None] * fwd
    stepping = (plan.labels != "still").astype(np.float64)
    both = feet.contact.all(axis=1).astype(np.float64)
    single = 1.0 - both
    bob = rng.uniform(0.004, 0.015)
    z = (
        body.stand_hip_z
        + bob * smooth((single - both) * stepping, 2.0)
        - pelvis_down
        + smooth_noise(rng, n, 20.0, 0.002)
    )
    roll = math.radians(rng.uniform(2.0, 5.0)) * (2.0 * w_com - 1.0)
    yaw_gain = math.radians(rng.uniform(3.0, 8.0)) / 0.25
    rise_m = feet.rise * feet.march
    yaw = heading + smooth(yaw_gain * (rise_m[:, 1] - rise_m[:, 0]), 2.0) + smooth_noise(rng, n, 20.0, 0.02)

    pos = np.concatenate([xy, z[:, None]], axis=1)
    rot = body_rotation(yaw, roll, np.zeros(n))
    ankles = feet.ankles(body)
    lmax = body.leg * 0.995
    _limit_lateral_reach(pos, rot, ankles, feet.contact, body, lmax, max_drop=0.05)
    for _ in range(3):
        hips = _hips(pos, rot, body)
        d_xy = np.linalg.norm(hips[..., :2] - ankles[..., :2], axis=-1)
        vmax = np.sqrt(np.maximum(lmax**2 - d_xy**2, 0.0))
        excess = (hips[..., 2] - (ankles[..., 2] + vmax)).max(axis=1)
        if excess.max() <= 0.0:
            break
        pos[:, 2] -= conservative_smooth(np.maximum(excess, 0.0) + 0.003 * (excess > 0), 21, 3.5)
    hips = _hips(pos, rot, body)
    return PelvisTrack(
        pos=pos,
        yaw=yaw,
        roll=roll,
        heading=heading,
        rot=rot,
        hips=hips,
        com=com,
        com_acc=com_acc,
        zmp=zmp,
        w_ref=w,
        w_com=w_com,
    )


def _limit_lateral_reach(
    pos: FloatArray,
    rot: FloatArray,
    ankles: FloatArray,
    contact: NDArray[np.bool_],
    body: Body,
    lmax: float,
    max_drop: float,
) -> None:
    """Keep the pelvis within reach of both feet at a modest knee bend (in place).

    Where the pendulum would carry the pelvis so far over one foot that the other
    (still loaded) leg could only reach its foot with a deep squat, the pelvis is pulled
    back towards that foot (smoothly); whatever remains, including the reach of a wide
    swing foot, is absorbed by bending the stance knee (lowering the pelvis) afterwards.
    """
    for _ in range(8):
        hips = _hips(pos, rot, body)
        dz = hips[..., 2] - max_drop - ankles[..., 2]
        rmax = np.sqrt(np.maximum(lmax**2 - dz**2, 0.0))
        dvec = ankles[..., :2] - hips[..., :2]
        r = np.linalg.norm(dvec, axis=-1)
        excess = np.where(contact, np.maximum(r - rmax, 0.0), 0.0)
        if excess.max() < 1e-4:
            return
        corr = (excess / np.maximum(r, 1e-9))[..., None] * dvec
        pos[:, :2] += smooth(1.3 * corr.sum(axis=1), 5.0)


def _hips(pos: FloatArray, rot: FloatArray, body: Body) -> FloatArray:
    """Left and right hip joint centres (T, 2, 3)."""
    left = pos + apply(rot, np.array([-body.hip_half, 0.0, 0.0]))
    right = pos + apply(rot, np.array([body.hip_half, 0.0, 0.0]))
    return np.stack([left, right], axis=1)
