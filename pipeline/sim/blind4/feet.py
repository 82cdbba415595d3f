"""Foot trajectories from the footstep plan (minimum-jerk swings with heel-off and toe landing)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.blind4.body import Body
from pipeline.sim.blind4.mathutil import bump, fwd_vec, min_jerk, smoothstep
from pipeline.sim.blind4.plan import Plan

FloatArray = NDArray[np.float64]


@dataclass
class FootTracks:
    """Per-frame foot state for both feet (index 0 = left, 1 = right)."""

    pos: FloatArray  # (T, 2, 2) horizontal ankle position
    yaw: FloatArray  # (T, 2) foot heading
    rise: FloatArray  # (T, 2) ankle height above its flat-foot height
    lift: FloatArray  # (T, 2) normalised swing height profile in [0, 1]
    contact: NDArray[np.bool_]  # (T, 2) ground-truth contact
    march: FloatArray  # (T, 2) 1 during marching swings (drives pelvis yaw / arm swing)

    def ankles(self, body: Body) -> FloatArray:
        """3D ankle joint positions (T, 2, 3)."""
        z = body.ankle_h + self.rise
        return np.concatenate([self.pos, z[..., None]], axis=-1)


def foot_tracks(plan: Plan) -> FootTracks:
    """Evaluate every swing of the plan on the frame grid."""
    n = plan.n_frames
    pos = np.repeat(plan.init_pos[None], n, axis=0).astype(np.float64)
    yaw = np.repeat(plan.init_yaw[None], n, axis=0).astype(np.float64)
    rise = np.zeros((n, 2))
    lift = np.zeros((n, 2))
    march = np.zeros((n, 2))
    contact = np.ones((n, 2), dtype=bool)
    for sw in sorted(plan.swings, key=lambda s: s.lo):
        f = sw.foot
        lo, td = sw.lo, min(sw.td, n)
        pos[sw.td :, f] = sw.p1
        yaw[sw.td :, f] = sw.yaw1
        if lo >= n:
            continue
        k = np.arange(lo, td)
        tau = (k - lo + 0.5) / (sw.td - lo)
        m = min_jerk(tau)
        b = bump(tau, sw.peak)
        heading = sw.yaw0 + (sw.yaw1 - sw.yaw0) * m
        fwd = fwd_vec(0.5 * (sw.yaw0 + sw.yaw1))
        pos[k, f] = sw.p0 + (sw.p1 - sw.p0) * m[:, None] + (sw.reach * b)[:, None] * fwd
        yaw[k, f] = heading
        rise[k, f] = sw.heel * (1.0 - m) + sw.land * m + sw.apex * b
        lift[k, f] = b
        contact[k, f] = False
        if sw.kind == "march":
            march[k, f] = 1.0
        if sw.heel_frames > 0 and sw.heel > 0:
            h0 = max(lo - sw.heel_frames, 0)
            kk = np.arange(h0, lo)
            rise[kk, f] = sw.heel * smoothstep((kk - (lo - sw.heel_frames) + 1.0) / (sw.heel_frames + 1.0))
        if sw.land_frames > 0 and sw.land > 0 and sw.td < n:
            kk = np.arange(sw.td, min(sw.td + sw.land_frames, n))
            rise[kk, f] = sw.land * (1.0 - smoothstep((kk - sw.td + 1.0) / (sw.land_frames + 1.0)))
    return FootTracks(pos=pos, yaw=yaw, rise=rise, lift=lift, contact=contact, march=march)
