"""Centre-of-mass layer (LIPM + DCM) and skeleton construction."""

import numpy as np
from scipy.ndimage import gaussian_filter1d, maximum_filter1d, minimum_filter1d
from scipy.signal import bilinear, lfilter

from pipeline.sim.blind7.timeline import FPS

G = 9.81
DT = 1.0 / FPS


def _n(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def so2(x, wn, zeta, gain=1.0):
    """Damped second-order response  y'' + 2 zeta wn y' + wn^2 y = gain wn^2 x."""
    b, a = bilinear([gain * wn * wn], [1.0, 2 * zeta * wn, wn * wn], fs=FPS)
    x = np.asarray(x, float)
    return lfilter(b, a, x - x[0], axis=0) + gain * x[0]


def dcm_com(p, omega):
    """CoM from a centre-of-pressure reference p (T,2) with the LIPM.

    The divergent component of motion xi = x + x'/omega obeys
    xi' = omega (xi - p). Planning it backwards from the final (rest) state
    gives the only bounded solution; the CoM then converges to xi with
    x' = omega (xi - x). p is held piecewise constant between frames.
    """
    T = len(p)
    e = np.exp(-omega * DT)
    pm = p.copy()
    pm[:-1] = 0.5 * (p[:-1] + p[1:])
    xi = np.empty_like(p)
    xi[-1] = p[-1]
    for f in range(T - 2, -1, -1):
        xi[f] = pm[f] + (xi[f + 1] - pm[f]) * e
    x = np.empty_like(p)
    x[0] = xi[0]
    # exact solution of x' = omega (xi - x) with xi varying linearly over a frame
    for f in range(T - 1):
        x0 = x[f]
        xa, xb = xi[f], xi[f + 1]
        slope = (xb - xa) / DT
        # x(t) = xi(t) - slope/omega + (x0 - xa + slope/omega) e^{-omega t}
        x[f + 1] = xb - slope / omega + (x0 - xa + slope / omega) * e
    return x, xi


def ik(hip, ank, a, b, pole):
    v = ank - hip
    d = np.linalg.norm(v, axis=1, keepdims=True)
    u = v / d
    d = np.clip(d, abs(a - b) + 1e-6, (a + b) * (1 - 1e-9))
    ca = np.clip((a * a + d * d - b * b) / (2 * a * d), -1, 1)
    sa = np.sqrt(1 - ca * ca)
    pv = pole - (pole * u).sum(1, keepdims=True) * u
    pv = _n(pv)
    return hip + a * (ca * u + sa * pv)


REACH = 0.72  # m from the room centre: hands are kept inside the tracked volume


def reach_governor(elbow, fa, up, farm):
    """Bend the forearm towards the trunk axis where the wrist would leave REACH."""
    al = np.linspace(0.0, 1.0, 11)
    need = np.ones(len(fa))
    for a in al[::-1]:
        f = _n((1 - a) * fa + a * up)
        r = np.linalg.norm((elbow + farm * f)[:, :2], axis=1)
        need = np.where(r <= REACH, a, need)
    need = np.where(np.linalg.norm((elbow + farm * fa)[:, :2], axis=1) <= REACH, 0.0, need)
    if not need.any():
        return fa
    need = gaussian_filter1d(maximum_filter1d(need, 13), 2.0, truncate=3.0)
    return _n((1 - need)[:, None] * fa + need[:, None] * up)


def build(tl):
    P, T, H = tl.P, tl.T, tl.P["H"]
    ank = tl.ank[:T].copy()
    con = tl.con[:T]
    fyaw = tl.fyaw[:T]
    ch = {k: v[:T] for k, v in tl.ch.items()}
    w = tl.w[:T].copy()
    w[con[:, 0] & ~con[:, 1]] = 1.0
    w[~con[:, 0] & con[:, 1]] = 0.0
    # centre of pressure reference: weighted ankles, a little towards the toes
    toe = 0.03 * H * np.stack([-np.sin(fyaw), np.cos(fyaw)], -1)  # (T,2,2)
    foot_p = ank[:, :, :2] + toe
    p = w[:, None] * foot_p[:, 0] + (1 - w[:, None]) * foot_p[:, 1]
    air = ~con[:, 0] & ~con[:, 1]
    for f in np.flatnonzero(air):
        p[f] = p[f - 1] if f > 0 else p[f]
    z_c = 0.56 * H
    omega = np.sqrt(G / z_c)
    com, xi = dcm_com(p, omega)
    acc = np.gradient(np.gradient(com, DT, axis=0), DT, axis=0)

    # pelvis orientation: circular mean of the foot yaws
    yu = np.unwrap(fyaw, axis=0)
    yu[:, 1] = yu[:, 0] + np.angle(np.exp(1j * (yu[:, 1] - yu[:, 0])))
    psi = gaussian_filter1d(0.5 * (yu[:, 0] + yu[:, 1]), 2.0)
    rp = np.stack([np.cos(psi), np.sin(psi)], 1)
    fp = np.stack([-np.sin(psi), np.cos(psi)], 1)
    mid = 0.5 * (ank[:, 0, :2] + ank[:, 1, :2])
    lat = ((com - gaussian_filter1d(mid, 8.0, axis=0)) * rp).sum(1)
    pel_xy = com - 0.02 * H * fp + (P["sway"] * 0.6 * lat)[:, None] * rp - ch["pel_back"][:, None] * fp

    # pelvic drop on the swing side (second-order response)
    drop = so2(3.0 * (np.pi / 180) * ((~con[:, 1]).astype(float) - (~con[:, 0]).astype(float)), 12.0, 0.8)
    hw = 0.5 * P["hipw"]
    right3 = np.stack([rp[:, 0] * np.cos(drop), rp[:, 1] * np.cos(drop), -np.sin(drop)], 1)

    # pelvis height: nominal + task offset, limited by leg reach (smooth clamp)
    L = P["thigh"] + P["shank"]
    Lmax = 0.998 * L
    z_t = P["ha"] + 0.99 * L + ch["zmod"]
    zmax = np.full(T, np.inf)
    for i, s in ((0, -1.0), (1, 1.0)):
        hxy = pel_xy + s * hw * right3[:, :2]
        dxy = np.linalg.norm(hxy - ank[:, i, :2], axis=1)
        dxy = np.minimum(dxy, 0.97 * Lmax)
        zmax = np.minimum(zmax, ank[:, i, 2] + np.sqrt(Lmax**2 - dxy**2) - s * hw * right3[:, 2])
    zsafe = gaussian_filter1d(minimum_filter1d(zmax, 9), 1.3, truncate=3.0)
    pz = np.minimum(z_t, zsafe)
    pel = np.concatenate([pel_xy, pz[:, None]], 1)
    hipL = pel - hw * right3
    hipR = pel + hw * right3
    fwd_foot = np.stack([-np.sin(fyaw), np.cos(fyaw), np.zeros_like(fyaw)], -1)
    # knees point forward (and a little outward)
    kneeL = ik(hipL, ank[:, 0], P["thigh"], P["shank"], fwd_foot[:, 0] - 0.1 * np.c_[rp, np.zeros(T)])
    kneeR = ik(hipR, ank[:, 1], P["thigh"], P["shank"], fwd_foot[:, 1] + 0.1 * np.c_[rp, np.zeros(T)])

    # arm swing drive from the foot lifts (left arm forward with right knee up)
    lift = ank[:, :, 2] - ank[:, :, 2].min()
    lift = np.where(con, 0.0, ank[:, :, 2] - P["ha"])
    drv = np.clip((lift[:, 1] - lift[:, 0]) / max(0.05, P["knee_lift"]), -1.2, 1.2)
    swing_L = so2(P["arm_amp"] * drv, 9.0, 0.45)
    swing_R = -swing_L
    # trunk: posture targets + damped responses to the CoM acceleration
    a_lat = (acc * rp).sum(1)
    a_fwd = (acc * fp).sum(1)
    pitch = ch["pitch"] + so2(np.clip(a_fwd, -8, 8), 7.0, 0.7, gain=-0.012)
    roll = ch["roll"] + so2(np.clip(a_lat, -8, 8), 7.0, 0.7, gain=0.015)
    cp, sp, cr, sr = np.cos(pitch), np.sin(pitch), np.cos(roll), np.sin(roll)
    up_t = _n(
        sr[:, None] * np.c_[rp, np.zeros(T)]
        + sp[:, None] * np.c_[fp, np.zeros(T)]
        + (cp * cr)[:, None] * np.array([0, 0, 1.0])
    )
    psi_s = psi + ch["tyaw"] - 0.25 * swing_L
    rs0 = np.stack([np.cos(psi_s), np.sin(psi_s), np.zeros(T)], 1)
    right_s = _n(rs0 - (rs0 * up_t).sum(1, keepdims=True) * up_t)
    fwd_s = np.cross(up_t, right_s)
    sc = pel + P["trunk"] * up_t
    shL = sc - 0.5 * P["shw"] * right_s
    shR = sc + 0.5 * P["shw"] * right_s

    # head
    psi_h = psi_s + ch["hyaw"] * (1 - P["look_gain"])
    ph = pitch + ch["hpitch"]
    z3 = np.array([0, 0, 1.0])
    rh = np.stack([np.cos(psi_h), np.sin(psi_h), np.zeros(T)], 1)
    f0 = np.stack([-np.sin(psi_h), np.cos(psi_h), np.zeros(T)], 1)
    uh = np.cos(ph)[:, None] * z3 + np.sin(ph)[:, None] * f0
    fh = np.cos(ph)[:, None] * f0 - np.sin(ph)[:, None] * z3
    piv = sc + 0.05 * H * up_t

    def hp(lat, f, u):
        return piv + H * (lat * rh + f * fh + u * uh)

    nose = hp(0.0, 0.055, 0.05)
    eyeL, eyeR = hp(-0.018, 0.045, 0.065), hp(0.018, 0.045, 0.065)
    earL, earR = hp(-0.045, 0.0, 0.055), hp(0.045, 0.0, 0.055)

    # arms
    t = np.arange(T) / FPS
    arms = []
    for side, sh, sw in (("L", shL, swing_L), ("R", shR, swing_R)):
        out = -right_s if side == "L" else right_s
        gp, gw = ch["point" + side], ch["wave" + side]
        gs, gf = np.clip(ch["stretch"], 0, 1), np.clip(ch["armfwd"], 0, 1)
        ab = (6 * np.pi / 180) + so2(np.clip(np.abs(a_lat), 0, 6), 5.0, 0.7, gain=0.02)
        # sagittal raise angle: swing, overhead stretch, arms forward (squat)
        s = (1 - gs - gf) * (sw + 4 * np.pi / 180) + gs * (165 * np.pi / 180) + gf * (55 * np.pi / 180)
        d_def = (
            (-np.cos(s) * np.cos(ab))[:, None] * up_t
            + (np.sin(s) * np.cos(ab))[:, None] * fwd_s
            + np.sin(ab)[:, None] * out
        )
        beta = P["elbow"] + 0.6 * np.maximum(sw, 0) * (1 - gs - gf) + gf * 0.6
        nn = fwd_s - (fwd_s * d_def).sum(1, keepdims=True) * d_def
        nn = _n(nn + 1e-6 * up_t)
        f_def = np.cos(beta)[:, None] * d_def + np.sin(beta)[:, None] * nn
        # forearm leads upwards while the arms are raised overhead
        f_def = _n(f_def + (2.0 * np.sin(np.pi * gs))[:, None] * up_t)
        g = np.clip(gp + gw, 0, 1)
        az = ch["pt_az"]
        el = ch["pt_elev"]
        d_pt = (
            np.cos(el)[:, None] * (np.cos(az)[:, None] * fwd_s + np.sin(az)[:, None] * out)
            + np.sin(el)[:, None] * up_t
        )
        d_wv = _n(0.6 * fwd_s + 0.45 * out + 0.6 * up_t)
        f_wv = _n(up_t + (0.4 * np.sin(2 * np.pi * ch["wave_f"] * t))[:, None] * out + 0.15 * fwd_s)
        # the arm is raised through the front: blend directions with an upward bias
        lift_up = (1.2 * np.sin(np.pi * g))[:, None] * (fwd_s + up_t)
        d = _n((1 - g)[:, None] * d_def + gp[:, None] * d_pt + gw[:, None] * d_wv + 0.5 * lift_up)
        fa = _n((1 - g)[:, None] * f_def + gp[:, None] * d_pt + gw[:, None] * f_wv + lift_up)
        el_ = sh + P["uarm"] * d
        fa = reach_governor(el_, fa, up_t, P["farm"])
        wr_ = el_ + P["farm"] * fa
        arms.append((el_, wr_))
    (elL, wrL), (elR, wrR) = arms
    J = np.stack(
        [
            nose,
            eyeL,
            eyeR,
            earL,
            earR,
            shL,
            shR,
            elL,
            elR,
            wrL,
            wrR,
            hipL,
            hipR,
            kneeL,
            kneeR,
            ank[:, 0],
            ank[:, 1],
        ],
        1,
    )
    return J, {"com": com, "cop": p, "xi": xi, "pelvis_z": pz}
