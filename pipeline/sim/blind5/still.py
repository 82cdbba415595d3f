"""Still behaviours (label `still`): keyed upper-body poses, turns, weight shifts."""

import itertools

import numpy as np

from pipeline.sim.blind5.timeline import fwd_vec, right_vec

IDLE_POSES = {  # (flex, abd, twist, elbow) for left and right arm
    "hips": ((-5, 45, 85, 95), (-5, 45, 85, 95)),
    "crossed": ((35, -5, 75, 112), (30, -8, 70, 105)),
    "behind": ((-25, 10, 70, 70), (-25, 10, 70, 70)),
    "clasped": ((15, 0, 60, 70), (15, 0, 60, 70)),
    "one-hip": ((3, 7, 10, 12), (-5, 45, 85, 95)),
}
ARM = ("flex", "abd", "twist", "elb")


def _hold(dur, rise, val, fall=None):
    fall = rise if fall is None else fall
    rise, fall = min(rise, 0.45 * dur), min(fall, 0.45 * dur)
    return [(0.0, 0.0), (rise, val), (dur - fall, val), (dur, 0.0)]


def _arm_pose(tl, a, dur, pre, pose, rise, fall=None):
    for name, v in zip(ARM, pose, strict=False):
        tl.add_keys(f"{pre}_{name}", a, _hold(dur, rise, v, fall))


def plain(tl, a, b, rng):
    pass


def sway(tl, a, b, rng):
    dur = (b - a - 1) / tl.fps
    th = tl.heading
    al, af = rng.uniform(0.015, 0.045), rng.uniform(0.0, 0.025)
    fq, ph = rng.uniform(0.25, 0.6), rng.uniform(0, 2 * np.pi)
    for t in np.arange(0.0, dur, 0.25 / fq)[1:]:
        e = min(1.0, t / 0.6, (dur - t) / 0.6)
        v = e * (
            al * np.sin(2 * np.pi * fq * t) * right_vec(th) + af * np.sin(np.pi * fq * t + ph) * fwd_vec(th)
        )
        tl.shift_keys.append((a + t * tl.fps, v))
    tl.shift_keys += [(a, np.zeros(2)), (b - 1, np.zeros(2))]


def gesture(tl, a, b, rng):
    dur = (b - a - 1) / tl.fps
    pre = "la" if rng.random() < 0.4 else "ra"
    kind = rng.choice(["wave", "point", "reach"])
    rise = rng.uniform(0.4, 0.8)
    if kind == "wave":
        pose = (rng.uniform(0, 30), rng.uniform(75, 105), -85, rng.uniform(80, 105))
        _arm_pose(tl, a, dur, pre, (*pose[:3], 12), rise)
        fq, amp = rng.uniform(1.5, 3.0), rng.uniform(15, 30)
        ts = np.arange(rise, dur - rise, 0.5 / fq)
        keys = [(0.0, 12.0)] + [(t, pose[3] + amp * (1 if i % 2 else -1)) for i, t in enumerate(ts)]
        tl.add_keys(f"{pre}_elb", a, [*keys, (dur, 12.0)], 0.3)
    elif kind == "point":
        _arm_pose(tl, a, dur, pre, (rng.uniform(70, 95), rng.uniform(5, 25), 0, rng.uniform(5, 15)), rise)
        tl.add_keys("hd_yaw", a, _hold(dur, rise, (1 if pre == "la" else -1) * rng.uniform(5, 25)))
    else:
        _arm_pose(tl, a, dur, pre, (rng.uniform(90, 140), rng.uniform(10, 30), 0, rng.uniform(10, 25)), rise)
        tl.add_keys("sp_pitch", a, _hold(dur, rise, rng.uniform(5, 15)))
        tl.add_keys("pel_y", a, _hold(dur, rise, -rng.uniform(0.0, 0.03)))


def look_around(tl, a, b, rng):
    dur = (b - a - 1) / tl.fps
    n = int(rng.integers(1, 4))
    n = max(1, min(n, int(dur / 1.3)))
    ts = (np.arange(1, n + 1) + rng.uniform(-0.15, 0.15, size=n)) / (n + 1) * dur
    s = rng.choice([-1.0, 1.0])
    yaws = [s * (-1) ** i * rng.uniform(30, 70) for i in range(n)]
    tl.add_keys("hd_yaw", a, [(0.0, 0.0), *list(zip(ts, yaws, strict=False)), (dur, 0.0)], 0.5)
    tl.add_keys(
        "sp_yaw", a, [(0.0, 0.0)] + [(t, 0.3 * y) for t, y in zip(ts, yaws, strict=False)] + [(dur, 0.0)], 0.5
    )
    tl.add_keys("hd_pitch", a, _hold(dur, 0.5, rng.uniform(-15, 15)))


def stretch(tl, a, b, rng):
    dur = (b - a - 1) / tl.fps
    rise = rng.uniform(0.6, 1.2)
    if rng.random() < 0.6:
        for pre in ("la", "ra"):
            _arm_pose(
                tl, a, dur, pre, (rng.uniform(155, 175), rng.uniform(8, 20), 0, rng.uniform(10, 30)), rise
            )
        tl.add_keys("sp_pitch", a, _hold(dur, rise, -rng.uniform(5, 12)))
        tl.add_keys("hd_pitch", a, _hold(dur, rise, -rng.uniform(10, 20)))
    else:
        s = rng.choice([-1.0, 1.0])  # lean towards s, opposite arm overhead
        pre = "la" if s > 0 else "ra"
        _arm_pose(tl, a, dur, pre, (rng.uniform(0, 20), rng.uniform(150, 170), 0, rng.uniform(10, 30)), rise)
        tl.add_keys("sp_roll", a, _hold(dur, rise, s * rng.uniform(10, 20)))


def bow(tl, a, b, rng):
    dur = (b - a - 1) / tl.fps
    down = rng.uniform(0.6, 1.2)
    tl.add_keys("sp_pitch", a, _hold(dur, down, rng.uniform(20, 45)))
    tl.add_keys("pel_pitch", a, _hold(dur, down, rng.uniform(5, 15)))
    tl.add_keys("hd_pitch", a, _hold(dur, down, rng.uniform(10, 25)))
    tl.add_keys("pel_y", a, _hold(dur, down, -rng.uniform(0.03, 0.08)))
    for pre in ("la", "ra"):
        tl.add_keys(f"{pre}_flex", a, _hold(dur, down, rng.uniform(15, 35)))


def crouch(tl, a, b, rng):
    dur = (b - a - 1) / tl.fps
    down = rng.uniform(0.6, 1.3)
    drop = rng.uniform(0.10, 0.35) * tl.body.height / 1.75
    tl.add_keys("pel_z", a, _hold(dur, down, -drop))
    tl.add_keys("pel_y", a, _hold(dur, down, -0.3 * drop))
    tl.add_keys("sp_pitch", a, _hold(dur, down, rng.uniform(15, 35)))
    tl.add_keys("pel_pitch", a, _hold(dur, down, rng.uniform(10, 25)))
    tl.add_keys("hd_pitch", a, _hold(dur, down, -rng.uniform(0, 15)))
    for pre in ("la", "ra"):
        _arm_pose(tl, a, dur, pre, (rng.uniform(30, 70), rng.uniform(5, 15), 0, rng.uniform(20, 60)), down)


def tiptoe(tl, a, b, rng):
    dur = (b - a - 1) / tl.fps
    up, rise = rng.uniform(0.4, 0.8), rng.uniform(0.03, 0.08)
    for c in ("heel_l", "heel_r", "pel_z"):
        tl.add_keys(c, a, _hold(dur, up, rise))
    for pre in ("la", "ra"):
        tl.add_keys(f"{pre}_abd", a, _hold(dur, up, rng.uniform(7, 25)))


def idle(tl, a, b, rng):
    dur = (b - a - 1) / tl.fps
    name = rng.choice(sorted(IDLE_POSES))
    lp, rp = IDLE_POSES[name]
    if name == "one-hip" and rng.random() < 0.5:
        lp, rp = rp, lp
    rise = rng.uniform(0.5, 1.0)
    _arm_pose(tl, a, dur, "la", lp, rise)
    _arm_pose(tl, a, dur, "ra", rp, rise)
    if rng.random() < 0.5:  # lean on one leg
        v = tl.feet[int(rng.integers(2))] - tl.feet.mean(0)
        v = v / max(np.linalg.norm(v), 1e-6) * rng.uniform(0.02, 0.05)
        tl.shift_keys += [
            (a, np.zeros(2)),
            (a + rise * tl.fps, v),
            (b - 1 - rise * tl.fps, v),
            (b - 1, np.zeros(2)),
        ]


def weight_shift(tl, a, b, rng):
    n = b - a
    half = n // 2 if (n > tl.fr(2.4) and rng.random() < 0.5) else n
    for s0 in range(a, a + n - half + 1, max(half, 1)):
        s1 = min(s0 + half, b)
        un = int(rng.integers(2))
        st = tl.feet[1 - un]
        v = st - tl.feet.mean(0)
        v = v / max(np.linalg.norm(v), 1e-6) * rng.uniform(0.04, 0.08)
        ramp = min(tl.fr(rng.uniform(0.4, 0.8)), (s1 - s0) // 3)
        tl.shift_keys += [(s0, np.zeros(2)), (s0 + ramp, v), (s1 - 1 - ramp, v), (s1 - 1, np.zeros(2))]
        mode = rng.choice(["none", "heel", "lift"])
        m0, m1 = s0 + ramp, s1 - 1 - ramp
        if m1 - m0 < 8:
            continue
        if mode == "heel":
            tl.add_frame_keys(
                "heel_l" if un == 0 else "heel_r",
                [m0, (m0 + m1) / 2, m1],
                [0.0, rng.uniform(0.01, 0.03), 0.0],
                1.0,
            )
        elif mode == "lift":
            B = tl.feet[un] + rng.normal(0.0, 0.01, size=2)
            tl.swing(un, m0 + 1, m1, B, None, zkeys=((0.0, 0.0), (0.5, rng.uniform(0.01, 0.04)), (1.0, 0.0)))
    tl.tags[a:b] = "weight-shift"


def turn(tl, a, b, rng):
    n_fr = b - a
    delta = np.deg2rad(rng.uniform(30, 180)) * rng.choice([-1.0, 1.0])
    nst = int(rng.integers(2, 7))
    sw, gap = rng.uniform(0.35, 0.6), rng.uniform(0.05, 0.3)
    while nst > 2 and tl.fr(nst * (sw + gap)) > n_fr - tl.fr(0.4):
        nst -= 1
    per = min(tl.fr(sw + gap), (n_fr - tl.fr(0.4)) // nst)
    swf = max(3, int(per * sw / (sw + gap)))
    c = tl.feet.mean(0)
    w = np.clip(np.linalg.norm(tl.feet[1] - tl.feet[0]), 0.6 * tl.style["width"], 1.3 * tl.style["width"])
    th0 = tl.heading
    first = 0 if delta > 0 else 1
    f = a + tl.fr(0.2)
    lift = rng.uniform(0.015, 0.06)
    for k in range(1, nst + 1):
        foot = first if k % 2 else 1 - first
        hk = th0 + delta * min(1.0, k / (nst - 1))
        B = c + right_vec(hk) * (-1 if foot == 0 else 1) * w / 2 + rng.normal(0.0, 0.008, size=2)
        v = tl.feet[1 - foot] - tl.feet.mean(0)
        tl.shift_keys += [(f, 0.03 * v / max(np.linalg.norm(v), 1e-6))]
        ap = np.clip(lift * rng.uniform(0.8, 1.2), 0.015, 0.06)
        tl.swing(foot, f, f + swf, B, hk, zkeys=((0.0, 0.0), (0.5, ap), (1.0, 0.0)))
        f += per
    tl.shift_keys += [(a, np.zeros(2)), (f, np.zeros(2))]
    tl.turn_heading(a + tl.fr(0.1), f - per + swf, th0 + delta)
    tl.add_keys("hd_yaw", a, [(0.0, 0.0), (0.3, np.rad2deg(delta) * 0.2), ((f - a) / tl.fps, 0.0)], 0.5)
    tl.tags[a:b] = "turn"


BEHAVIOURS = {
    "": (plain, 0.10, 1.0),
    "turn": (turn, 0.13, 1.8),
    "weight-shift": (weight_shift, 0.12, 1.4),
    "sway": (sway, 0.08, 1.5),
    "gesture": (gesture, 0.10, 1.6),
    "look-around": (look_around, 0.09, 1.5),
    "stretch": (stretch, 0.07, 2.0),
    "bow": (bow, 0.06, 1.8),
    "crouch": (crouch, 0.07, 1.8),
    "tiptoe": (tiptoe, 0.06, 1.4),
    "idle": (idle, 0.12, 1.6),
}


def fill_still(tl, a, b, rng):
    """Populate a still stretch [a, b) with one or two behaviours plus plain standing."""
    m0, m1 = tl.fr(0.4), tl.fr(0.45)
    avail = b - a - m0 - m1
    if avail < tl.fr(1.0):
        return
    parts = 2 if (avail > tl.fr(3.6) and rng.random() < 0.4) else 1
    edges = np.linspace(a + m0, b - m1, parts + 1).astype(int)
    names = list(BEHAVIOURS)
    w = np.array([BEHAVIOURS[k][1] for k in names])
    for s0, s1 in itertools.pairwise(edges):
        length = int((s1 - s0) * rng.uniform(0.7, 1.0)) if parts == 1 else s1 - s0 - tl.fr(0.1)
        ok = [BEHAVIOURS[k][2] * tl.fps <= length for k in names]
        if not any(ok):
            continue
        p = w * np.array(ok)
        name = names[rng.choice(len(names), p=p / p.sum())]
        w0 = s0 + int(rng.integers(0, s1 - s0 - length + 1))
        BEHAVIOURS[name][0](tl, w0, w0 + length, rng)
        tl.tags[w0 : w0 + length] = name
