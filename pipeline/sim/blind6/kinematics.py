"""Forward kinematics of the skeleton, two-link leg IK onto the pinned / swinging ankles."""

import numpy as np
from scipy.ndimage import gaussian_filter1d, maximum_filter1d

# COCO-17
NOSE, LEYE, REYE, LEAR, REAR, LSH, RSH, LEL, REL, LWR, RWR, LHIP, RHIP, LKNEE, RKNEE, LANK, RANK = range(17)


def _rx(a):
    c, s, o, z = np.cos(a), np.sin(a), np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def _ry(a):
    c, s, o, z = np.cos(a), np.sin(a), np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def _rz(a):
    c, s, o, z = np.cos(a), np.sin(a), np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def _mm(A, B):
    return np.einsum("tij,tjk->tik", A, B)


def _mv(R, v):
    v = np.broadcast_to(v, R.shape[:-1])
    return np.einsum("tij,tj->ti", R, v)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def leg_ik(hip, ank, L1, L2, pole):
    """Knee from hip, ankle target and a pole direction; returns (knee, ankle)."""
    d = ank - hip
    dist = np.linalg.norm(d, axis=-1)
    u = d / dist[:, None]
    dc = np.clip(dist, abs(L1 - L2) + 1e-4, L1 + L2 - 1e-7)
    a = (L1 * L1 - L2 * L2 + dc * dc) / (2 * dc)
    h = np.sqrt(np.maximum(L1 * L1 - a * a, 0.0))
    p = _unit(pole - np.sum(pole * u, -1, keepdims=True) * u)
    knee = hip + a[:, None] * u + h[:, None] * p
    ank_out = knee + L2 * _unit(hip + dc[:, None] * u - knee)
    return knee, ank_out


def support_base(feet, con, sigma=4.0):
    """Mid-point of the last loaded position of each foot, smoothed in time."""
    T = len(feet)
    held = np.empty((T, 2, 2))
    for i in (0, 1):
        idx = np.where(con[:, i], np.arange(T), 0)
        idx = np.maximum.accumulate(idx)
        held[:, i] = feet[idx, i, :2]
    return gaussian_filter1d(held.mean(1), sigma, axis=0, mode="nearest")


def assemble(body, D):
    """D: dict of per-frame parameters (see motion.SCAL / ARMS). Returns joints (T, 17, 3)."""
    b = body
    feet = D["feet"]
    T = len(feet)
    th = D["heading"]
    Rh = _rz(th)
    off = np.stack([D["px"], D["py"], np.zeros(T)], -1)
    pel = np.zeros((T, 3))
    w = D["pabs_w"][:, None]
    pel[:, :2] = (1 - w) * (D["base"] + _mv(Rh, off)[:, :2]) + w * D["pabs"]
    pel[:, 2] = b.pel_z0 - D["pz"] + D["lift"]
    Rp = _mm(_mm(_rz(th + D["pyaw"]), _rx(-D["ptilt"])), _ry(D["proll"]))
    hip_off = np.array([0.5 * b.hip_w, 0.0, 0.0])
    hips = np.stack([pel + _mv(Rp, -hip_off), pel + _mv(Rp, hip_off)], 1)
    # stance constraint: lower the pelvis where an ankle would be out of reach
    Lm = 0.995 * b.leg
    dxy = np.linalg.norm(hips[:, :, :2] - feet[:, :, :2], axis=-1)
    zmax = feet[:, :, 2] + np.sqrt(np.maximum(Lm**2 - dxy**2, (0.3 * b.leg) ** 2))
    corr = np.maximum(0.0, (hips[:, :, 2] - zmax).max(1))
    if corr.any():
        cs = gaussian_filter1d(maximum_filter1d(corr, 9), 2.0)
        corr = np.maximum(corr, cs)
        pel[:, 2] -= corr
        hips[:, :, 2] -= corr[:, None]
    J = np.zeros((T, 17, 3))
    Ryaw = _rz(th + D["pyaw"])
    for i, (hj, kj, aj, sg) in enumerate(((LHIP, LKNEE, LANK, -1), (RHIP, RKNEE, RANK, 1))):
        pole = _mv(Ryaw, np.array([sg * np.sin(b.toe_out), np.cos(b.toe_out), 0.0]))
        knee, ank = leg_ik(hips[:, i], feet[:, i], b.thigh, b.shank, pole)
        J[:, hj], J[:, kj], J[:, aj] = hips[:, i], knee, ank
    Rt = _mm(_mm(_mm(Rp, _rx(-D["tflex"])), _ry(D["tlat"])), _rz(D["ttwist"]))
    nb = pel + _mv(Rt, np.array([0.0, 0.0, b.trunk]))
    for sg, sj, ej, wj, a in ((-1, LSH, LEL, LWR, 0), (1, RSH, REL, RWR, 1)):
        sh = nb + _mv(Rt, np.array([0.5 * sg * b.sh_w, 0.0, -b.sh_drop]))
        sf, sa, el, tw = (D[k][:, a] for k in ("sf", "sa", "el", "tw"))
        u = np.stack([sg * np.sin(sa) * np.cos(sf), np.sin(sf), -np.cos(sa) * np.cos(sf)], -1)
        ff = np.array([0.0, 1.0, 0.0]) - u[:, 1:2] * u
        fu = np.array([0.0, 0.0, 1.0]) - u[:, 2:3] * u
        nf = np.linalg.norm(ff, axis=-1, keepdims=True)
        f = _unit(ff + 0.35 * (1 - nf) * fu + 1e-9)
        p = np.cos(tw)[:, None] * f + sg * np.sin(tw)[:, None] * np.cross(u, f)
        fa = np.cos(el)[:, None] * u + np.sin(el)[:, None] * p
        elbow = sh + b.upper * _mv(Rt, u)
        J[:, sj], J[:, ej], J[:, wj] = sh, elbow, elbow + b.fore * _mv(Rt, _unit(fa))
    Rhd = _mm(_mm(_mm(Rt, _rz(D["hyaw"])), _rx(-D["hpitch"])), _ry(D["hroll"]))
    hc = nb + _mv(Rhd, np.array([0.0, 0.0, b.neck]))
    for j, o in zip((NOSE, LEYE, REYE, LEAR, REAR), b.face, strict=False):
        J[:, j] = hc + _mv(Rhd, o)
    return J
