"""Still behaviours: everything a person does in the CAVE without stepping to travel.

Each function fills frames sl = [k0, k0 + n) of the timeline; all posture offsets are zero at
both ends of the segment so segments join continuously."""

import numpy as np

from pipeline.sim.blind6.motion import FPS, R_FOOT, env, fwd, jit2, keys, s01


def _f(s):
    return round(s * FPS)


def plain(tl, sl, n, rng):
    tl.tags[sl] = ""


def idle(tl, sl, n, rng):
    e = env(n, _f(0.6), _f(0.6))
    A = tl.A
    v = rng.integers(4)
    if v == 0:  # hands together in front
        A["sf"][sl] += e[:, None] * rng.uniform(0.2, 0.5)
        A["el"][sl] += e[:, None] * rng.uniform(1.0, 1.5)
        A["tw"][sl] += e[:, None] * -0.6
    elif v == 1:  # hands on hips
        A["sa"][sl] += e[:, None] * rng.uniform(0.4, 0.7)
        A["el"][sl] += e[:, None] * rng.uniform(1.4, 1.8)
        A["tw"][sl] += e[:, None] * -1.2
    elif v == 2:  # touch the face / scratch the head
        a = int(rng.integers(2))
        A["sf"][sl, a] += e * rng.uniform(0.5, 1.6)
        A["sa"][sl, a] += e * rng.uniform(0.1, 0.5)
        A["el"][sl, a] += e * rng.uniform(1.9, 2.4)
    else:  # shifting arms
        A["sf"][sl] += e[:, None] * rng.normal(0, 0.15, 2)
        A["el"][sl] += e[:, None] * rng.uniform(0.1, 0.6, 2)
    t = np.arange(n) / FPS
    tl.P["px"][sl] += e * rng.uniform(0.005, 0.02) * np.sin(2 * np.pi * rng.uniform(0.1, 0.3) * t)
    tl.tags[sl] = "idle"


def sway(tl, sl, n, rng):
    t = np.arange(n) / FPS
    e = env(n, _f(0.8), _f(0.8))
    s = np.sin(2 * np.pi * rng.uniform(0.2, 0.6) * t + rng.uniform(0, 2 * np.pi))
    a = rng.uniform(0.02, 0.06)
    tl.P["px"][sl] += e * a * s
    tl.P["tlat"][sl] -= e * a * 2.0 * s
    tl.P["proll"][sl] += e * a * 1.0 * s
    tl.P["py"][sl] += e * rng.uniform(0, 0.02) * np.sin(2 * np.pi * rng.uniform(0.1, 0.3) * t)
    tl.tags[sl] = "sway"


def dance(tl, sl, n, rng):
    k0 = sl.start
    t = np.arange(n) / FPS
    f = rng.uniform(0.8, 2.0)
    e = env(n, _f(0.5), _f(0.5))
    P, A = tl.P, tl.A
    ph = rng.uniform(0, 2 * np.pi)
    P["pz"][sl] += e * rng.uniform(0.01, 0.05) * (0.5 - 0.5 * np.cos(2 * np.pi * f * t))
    P["px"][sl] += e * rng.uniform(0.01, 0.05) * np.sin(np.pi * f * t + ph)
    P["pyaw"][sl] += e * rng.uniform(0.0, 0.15) * np.sin(np.pi * f * t + ph)
    P["tlat"][sl] += e * rng.uniform(0.0, 0.08) * np.sin(np.pi * f * t + ph + 1)
    P["hroll"][sl] += e * rng.uniform(0, 0.1) * np.sin(np.pi * f * t)
    P["hpitch"][sl] += e * rng.uniform(0, 0.08) * np.sin(2 * np.pi * f * t)
    aa = rng.uniform(0.1, 0.9)
    for a in (0, 1):
        A["sf"][sl, a] += e * (aa * np.sin(np.pi * f * t + a * np.pi) + rng.uniform(0, 0.5))
        A["el"][sl, a] += e * rng.uniform(0.3, 1.4)
        A["sa"][sl, a] += e * rng.uniform(0, 0.4) * (1 + np.sin(2 * np.pi * f * t)) / 2
    # small foot taps on the beat, landing back on the same spot
    beat = FPS / f
    k = k0 + int(rng.integers(6, 15))
    foot = int(rng.integers(2))
    while True:
        ns = max(5, int(0.8 * beat))
        if k + ns + 8 > k0 + n:
            break
        if rng.random() < 0.6:
            p1 = tl.cur[foot].copy()
            p1[:2] += jit2(rng, 0.004, 0.006)
            tl.swing(foot, k, ns, p1, rng.uniform(0.01, 0.04))
            foot = 1 - foot
        k += round(2 * beat)
    tl.tags[sl] = "dance"


def weight_shift(tl, sl, n, rng):
    k0 = sl.start
    m = int(np.clip(n // _f(1.2), 1, 3))
    m = int(rng.integers(1, m + 1))
    seg = n // m
    s = rng.choice([-1.0, 1.0])
    for j in range(m):
        a = k0 + j * seg
        L = seg if j < m - 1 else n - j * seg
        e = env(L, L // 3, L // 3)
        tl.P["px"][a : a + L] += s * 0.5 * tl.b.stance * rng.uniform(0.5, 0.9) * e
        tl.P["tlat"][a : a + L] -= s * rng.uniform(0.0, 0.06) * e
        tl.P["proll"][a : a + L] += s * rng.uniform(0.0, 0.06) * e
        free = 0 if s > 0 else 1  # the unloaded foot
        if rng.random() < 0.4 and L >= 24:
            ns = int(rng.integers(6, 16))
            ks = a + L // 2 - ns // 2
            p1 = tl.cur[free].copy()
            p1[:2] += jit2(rng, 0.004, 0.008)
            tl.swing(free, ks, ns, p1, rng.uniform(0.01, 0.04))
        else:
            e2 = env(L, int(L / 2.5), int(L / 2.5))
            tl.feet[a : a + L, free, 2] += rng.uniform(0.0, 0.05) * e2  # heel rise, still loaded
        s = -s
    tl.tags[sl] = "weight-shift"


def look_around(tl, sl, n, rng):
    m = int(rng.integers(2, 5))
    sg = rng.choice([-1.0, 1.0])
    yaw = [0.0] + [sg * (-1) ** j * rng.uniform(0.3, 1.3) for j in range(m)] + [0.0]
    pit = [0.0, *list(rng.uniform(-0.35, 0.3, m)), 0.0]
    y = keys(n, yaw)
    tl.P["hyaw"][sl] += y
    tl.P["hpitch"][sl] += keys(n, pit)
    tl.P["ttwist"][sl] += rng.uniform(0.15, 0.4) * y
    tl.tags[sl] = "look-around"


def gesture(tl, sl, n, rng):
    t = np.arange(n) / FPS
    e = env(n, _f(rng.uniform(0.6, 1.0)), _f(rng.uniform(0.6, 1.0)))
    A = tl.A
    a = int(rng.integers(2))
    if rng.random() < 0.5:  # pointing
        A["sf"][sl, a] += e * rng.uniform(1.1, 1.8)
        A["sa"][sl, a] += e * rng.uniform(-0.2, 0.5)
        A["el"][sl, a] += e * rng.uniform(-0.1, 0.2)
        tl.P["hyaw"][sl] += e * (1 if a else -1) * rng.uniform(0.0, 0.4)
    else:  # waving
        A["sa"][sl, a] += e * rng.uniform(1.7, 2.4)
        A["sf"][sl, a] += e * rng.uniform(0.1, 0.4)
        A["el"][sl, a] += e * rng.uniform(0.8, 1.5)
        A["tw"][sl, a] += e * (1.2 + rng.uniform(0.3, 0.6) * np.sin(2 * np.pi * rng.uniform(1.5, 3.0) * t))
        if rng.random() < 0.3:
            b = 1 - a
            A["sa"][sl, b] += e * rng.uniform(1.7, 2.4)
            A["el"][sl, b] += e * rng.uniform(0.8, 1.5)
            A["tw"][sl, b] += e * (1.2 + 0.4 * np.sin(2 * np.pi * 2.0 * t + 1.0))
    tl.tags[sl] = "gesture"


def stretch(tl, sl, n, rng):
    e = env(n, _f(rng.uniform(0.8, 1.4)), _f(rng.uniform(0.8, 1.4)))
    A, P = tl.A, tl.P
    v = rng.integers(3)
    if v == 1:  # arms out to the sides
        A["sa"][sl] += e[:, None] * rng.uniform(1.3, 1.6)
        A["el"][sl] += e[:, None] * rng.uniform(-0.1, 0.1)
    else:  # overhead, optionally bending sideways
        A["sf"][sl] += e[:, None] * rng.uniform(2.5, 2.9)
        A["el"][sl] += e[:, None] * rng.uniform(0.0, 0.3)
        P["tflex"][sl] -= e * rng.uniform(0.05, 0.2)
        if v == 2:
            P["tlat"][sl] += e * rng.choice([-1, 1]) * rng.uniform(0.15, 0.35)
    P["hpitch"][sl] -= e * rng.uniform(0.0, 0.3)
    tl.tags[sl] = "stretch"


def _dip(n, rng, dn=(0.6, 1.2), up=(0.7, 1.3)):
    a, b = _f(rng.uniform(*dn)), _f(rng.uniform(*up))
    scale = min(1.0, (n - 4) / (a + b + 1))
    a, b = max(3, int(a * scale)), max(3, int(b * scale))
    prof = np.ones(n)
    prof[:2] = 0
    prof[2 : 2 + a] = s01(np.arange(a) / a)
    prof[n - 2 - b :] = np.minimum(prof[n - 2 - b :], s01(np.arange(b + 2)[::-1] / b))
    return prof, n - 2 - b


def bow(tl, sl, n, rng):
    pr, _ = _dip(n, rng)
    f = rng.uniform(0.3, 0.8)
    tl.P["tflex"][sl] += f * pr
    tl.P["hpitch"][sl] += rng.uniform(0.1, 0.4) * pr
    tl.P["py"][sl] -= 0.05 * f * pr
    tl.A["sf"][sl] += (0.8 * f * pr)[:, None]
    tl.tags[sl] = "bow"


def lean(tl, sl, n, rng):
    pr, _ = _dip(n, rng)
    P, A = tl.P, tl.A
    if rng.random() < 0.4:
        f = rng.uniform(0.35, 0.7)
        P["tflex"][sl] += f * pr
        P["py"][sl] -= rng.uniform(0.03, 0.08) * pr
        A["sf"][sl] += (rng.uniform(0.5, 1.0) * f * pr)[:, None]
    else:
        s = rng.choice([-1.0, 1.0])
        f = rng.uniform(0.2, 0.55)
        P["tlat"][sl] += s * f * pr
        P["px"][sl] -= s * rng.uniform(0.02, 0.07) * pr
        far = 0 if s > 0 else 1
        A["sa"][sl, far] += rng.uniform(0.0, 1.5) * pr
        A["sa"][sl, 1 - far] -= 0.6 * f * pr
    tl.tags[sl] = "lean"


def crouch(tl, sl, n, rng):
    pr, k_up = _dip(n, rng)
    P, A = tl.P, tl.A
    P["pz"][sl] += rng.uniform(0.15, 0.32) * tl.b.leg * pr
    P["py"][sl] -= rng.uniform(0.02, 0.08) * pr
    f = rng.uniform(0.25, 0.6)
    P["tflex"][sl] += f * pr
    P["hpitch"][sl] -= 0.4 * f * pr
    A["sf"][sl] += (rng.uniform(0.3, 1.0) * pr)[:, None]
    A["el"][sl] += (rng.uniform(0.2, 0.8) * pr)[:, None]
    tl.tags[sl] = "crouch"
    tl.tags[sl.start + k_up : sl.stop] = "stand-up"


def squat(tl, sl, n, rng):
    reps = int(np.clip(n // _f(1.6), 1, 3))
    reps = int(rng.integers(1, reps + 1))
    seg = n // reps
    P, A = tl.P, tl.A
    for j in range(reps):
        a = sl.start + j * seg
        L = seg if j < reps - 1 else n - j * seg
        pr, _ = _dip(L, rng, (0.5, 1.0), (0.5, 1.0))
        s = slice(a, a + L)
        P["pz"][s] += rng.uniform(0.30, 0.45) * tl.b.leg * pr
        P["py"][s] -= rng.uniform(0.05, 0.12) * pr
        P["tflex"][s] += rng.uniform(0.4, 0.8) * pr
        A["sf"][s] += (rng.uniform(1.0, 1.5) * pr)[:, None]
    tl.tags[sl] = "squat"


def pick_up(tl, sl, n, rng):
    pr, _ = _dip(n, rng, (0.8, 1.2), (0.8, 1.2))
    P, A = tl.P, tl.A
    f = rng.uniform(0.9, 1.5)
    P["tflex"][sl] += f * pr
    P["pz"][sl] += rng.uniform(0.05, 0.25) * tl.b.leg * pr
    P["py"][sl] -= rng.uniform(0.03, 0.1) * pr
    P["hpitch"][sl] += rng.uniform(0.0, 0.3) * pr
    arms = [int(rng.integers(2))] if rng.random() < 0.7 else [0, 1]
    for a in (0, 1):
        A["sf"][sl, a] += (0.85 * f + (rng.uniform(0, 0.3) if a in arms else -0.1)) * pr
        A["el"][sl, a] += rng.uniform(0.0, 0.4) * pr
    tl.tags[sl] = "pick-up"


def tiptoe(tl, sl, n, rng):
    e = env(n, _f(rng.uniform(0.6, 1.0)), _f(rng.uniform(0.6, 1.0)))
    h = rng.uniform(0.03, 0.07) * e
    tl.feet[sl, :, 2] += h[:, None]  # both heels up, balls of the feet loaded
    tl.P["lift"][sl] += h
    if rng.random() < 0.5:
        tl.A["sf"][sl] += (rng.uniform(2.0, 2.8) * e)[:, None]
        tl.P["hpitch"][sl] -= 0.3 * e
    tl.tags[sl] = "tiptoe"


def jump(tl, sl, n, rng):
    k = sl.start + 3
    end = sl.stop
    P, A = tl.P, tl.A
    nj = 2 if (n > _f(2.4) and rng.random() < 0.5) else 1
    for _ in range(nj):
        h = rng.uniform(0.03, 0.12)
        nfl = max(3, round(np.sqrt(8 * h / 9.81) * FPS))
        d = rng.uniform(0.06, 0.14) * tl.b.leg
        npre, npush, nland, nrec = _f(rng.uniform(0.35, 0.5)), 4, 4, _f(rng.uniform(0.3, 0.45))
        if k + npre + npush + nfl + nland + nrec + 2 > end:
            break
        P["pz"][k : k + npre] += d * s01(np.arange(npre) / npre)
        A["sf"][k : k + npre] -= (0.6 * s01(np.arange(npre) / npre))[:, None]
        k += npre
        P["pz"][k : k + npush] += d * (1 - s01(np.arange(1, npush + 1) / npush))
        nsw = npush + nfl
        A["sf"][k : k + nsw] += (-0.6 + 1.1 * s01(np.arange(1, nsw + 1) / nsw))[:, None]
        k += npush
        s = np.arange(1, nfl + 1) / (nfl + 1)
        par = 4 * h * s * (1 - s)
        P["lift"][k : k + nfl] += par
        for i in (0, 1):
            p0 = tl.cur[i].copy()
            p1 = p0.copy()
            p1[:2] += jit2(rng, 0.004, 0.008)
            tl.feet[k : k + nfl, i] = p0 + (p1 - p0) * s01(s)[:, None]
            tl.feet[k : k + nfl, i, 2] += par
            tl.con[k : k + nfl, i] = False
            tl.put(i, k + nfl, p1)
        k += nfl
        P["pz"][k : k + nland] += 0.8 * d * s01(np.arange(1, nland + 1) / nland)
        nb = nland + nrec
        A["sf"][k : k + nb] += (0.5 * (1 - s01(np.arange(1, nb + 1) / nb)))[:, None]
        k += nland
        P["pz"][k : k + nrec] += 0.8 * d * (1 - s01(np.arange(1, nrec + 1) / nrec))
        k += nrec + 2
    tl.tags[sl] = "jump"


def kneel_geometry(tl):
    b = tl.b
    zk = 0.028 * b.height
    dl = 0.1 * b.thigh
    zh = zk + np.sqrt(b.thigh**2 - dl**2)
    yp = -0.04
    za = b.ankle_h + 0.02 * b.height
    yB = yp + dl - np.sqrt(b.shank**2 - (za - zk) ** 2)
    yF = yp + 0.85 * b.thigh
    return zh, yp, za, yB, yF


def kneel_ok(tl):
    _, _, _, yB, yF = kneel_geometry(tl)
    F = fwd(tl.theta)
    return all(np.linalg.norm(tl.home(i)[:2] + F * y) < R_FOOT for i in (0, 1) for y in (yB, yF))


def kneel(tl, sl, n, rng):
    """Step one foot forward, the other back, go down onto the back knee, hold, get up."""
    b = tl.b
    F = fwd(tl.theta)
    zh, yp, za, yB, yF = kneel_geometry(tl)
    kl = int(rng.integers(2))
    fl = 1 - kl
    homes = [tl.home(0), tl.home(1)]
    front = homes[fl].copy()
    front[:2] += F * yF
    back = homes[kl].copy()
    back[:2] += F * yB
    n1, n2, n3, n5, n6, n7 = (
        _f(0.45),
        _f(0.55),
        _f(rng.uniform(0.8, 1.3)),
        _f(rng.uniform(0.8, 1.3)),
        _f(0.55),
        _f(0.45),
    )
    g = 3
    n4 = n - (n1 + n2 + n3 + n5 + n6 + n7 + 5 * g)
    if n4 < 3:
        raise ValueError("kneel segment too short")
    k = sl.start + g
    tl.swing(fl, k, n1, front, rng.uniform(0.02, 0.05))
    k += n1 + g
    kb = k
    tl.swing(kl, k, n2, back, rng.uniform(0.02, 0.05))
    k += n2
    down = s01(np.arange(1, n3 + 1) / n3)
    tl.feet[k : k + n3, kl, 2] += (za - b.ankle_h) * down  # heel rises onto the ball
    P = tl.P
    P["pz"][k : k + n3] += (b.pel_z0 - zh) * down
    k += n3
    tl.feet[k : k + n4, kl, 2] = za
    P["pz"][k : k + n4] += b.pel_z0 - zh
    k += n4
    up = 1 - s01(np.arange(1, n5 + 1) / n5)
    tl.feet[k : k + n5, kl, 2] += (za - b.ankle_h) * up
    P["pz"][k : k + n5] += (b.pel_z0 - zh) * up
    ke = k + n5
    k = ke + g
    tl.swing(kl, k, n6, homes[kl], rng.uniform(0.02, 0.05))
    k += n6 + g
    tl.swing(fl, k, n7, homes[fl], rng.uniform(0.02, 0.05))
    w = np.zeros(n)
    a0, a1, b0, b1 = kb - sl.start, kb - sl.start + n2 + n3, ke - sl.start - n5, ke - sl.start + g + n6
    w[a0:a1] = s01(np.arange(a1 - a0) / (a1 - a0))
    w[a1:b0] = 1.0
    w[b0:b1] = 1 - s01(np.arange(1, b1 - b0 + 1) / (b1 - b0))
    P["pabs_w"][sl] = w
    tl.pabs[sl] = tl.c + F * yp
    P["tflex"][sl] += rng.uniform(0.05, 0.25) * w
    tl.A["sf"][sl] += (rng.uniform(0.0, 0.5) * w)[:, None]
    tl.A["el"][sl] += (rng.uniform(0.0, 0.8) * w)[:, None]
    tl.tags[sl] = "kneel"


def turn(tl, sl, n, rng):
    """Turn on the spot with 2-6 small pivot steps."""
    k0 = sl.start
    th0 = tl.theta
    ang = rng.choice([-1.0, 1.0]) * np.radians(rng.uniform(30, 180))
    ns = int(np.clip(round(n / FPS / 0.6), 2, 6))
    slot = (n - 6) // ns
    sw = max(6, int(slot * rng.uniform(0.55, 0.75)))
    first = 0 if ang > 0 else 1
    r = np.linalg.norm(tl.c)  # pivot steps also drift a few cm back towards the centre
    c = tl.c * (1 - min(1.0, rng.uniform(0.0, 0.06) / max(r, 1e-6)))
    tl.heading[sl] = th0 + ang * keys(n, [0.0, 1.0])
    for j in range(ns):
        i = first if j % 2 == 0 else 1 - first
        frac = min(1.0, (j + 1) / (ns - 1))
        tgt = tl.home(i, c, th0 + ang * frac)
        tgt[:2] += jit2(rng, 0.005, 0.01)
        tl.swing(i, k0 + 3 + j * slot, sw, tgt, rng.uniform(0.01, 0.05))
    tl.theta = float((th0 + ang + np.pi) % (2 * np.pi) - np.pi)
    tl.heading[sl.stop - 1] = th0 + ang  # exact end value (unwrapped)
    tl.tags[sl] = "turn"


# name: (function, min s, max s, weight)
STILL = {
    "plain": (plain, 0.5, 6.0, 2.5),
    "idle": (idle, 1.5, 6.0, 2.0),
    "sway": (sway, 2.0, 6.0, 1.0),
    "dance": (dance, 2.0, 6.0, 0.8),
    "weight-shift": (weight_shift, 1.5, 6.0, 1.5),
    "look-around": (look_around, 1.5, 5.0, 1.2),
    "gesture": (gesture, 1.5, 5.0, 1.2),
    "stretch": (stretch, 2.0, 5.0, 0.7),
    "bow": (bow, 1.5, 4.0, 0.5),
    "lean": (lean, 1.5, 5.0, 0.8),
    "crouch": (crouch, 2.5, 6.0, 0.8),
    "squat": (squat, 2.0, 6.0, 0.5),
    "pick-up": (pick_up, 2.0, 5.0, 0.7),
    "tiptoe": (tiptoe, 1.5, 4.0, 0.6),
    "jump": (jump, 1.3, 3.0, 0.6),
    "kneel": (kneel, 5.0, 6.0, 0.5),
    "turn": (turn, 1.2, 4.0, 1.5),
}
