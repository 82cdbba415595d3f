"""Person styles, stepping bouts (footstep plans) and still behaviours."""

import numpy as np

from pipeline.sim.blind7.timeline import FPS, Timeline, envelope, fwd_of, mj, right_of

D2R = np.pi / 180.0
LABEL_ID = {"still": 0, "forward": 1, "left": 2, "right": 3}
STILL_BEHAVIOURS = (
    "stand",
    "weight_shift",
    "point",
    "wave",
    "look_around",
    "turn",
    "stretch",
    "bow",
    "lean",
    "squat",
    "kneel",
    "tiptoe",
    "jump",
    "sway",
)
STILL_P = np.array([1.0, 1.2, 0.9, 0.9, 1.0, 1.3, 0.6, 0.6, 0.6, 0.7, 0.5, 0.6, 0.6, 0.8])
ROOM_R = 0.08  # the stance centre stays within this radius of the room centre


def make_person(rng):
    H = rng.uniform(1.40, 2.05)
    P = {"H": H}
    P["thigh"] = H * rng.uniform(0.235, 0.255)
    P["shank"] = H * rng.uniform(0.235, 0.255)
    P["ha"] = H * rng.uniform(0.040, 0.050)
    P["hipw"] = H * rng.uniform(0.100, 0.125)
    P["shw"] = H * rng.uniform(0.190, 0.225)
    P["uarm"] = H * rng.uniform(0.165, 0.185)
    P["farm"] = H * rng.uniform(0.140, 0.155)
    P["trunk"] = H * rng.uniform(0.280, 0.310)
    P["stance"] = P["hipw"] * rng.uniform(0.85, 1.30)
    P["cadence"] = rng.uniform(0.5, 2.6)  # steps / s
    P["swing_max"] = rng.uniform(0.30, 0.80)  # s
    P["ds"] = rng.uniform(0.10, 0.45)  # double-support share of a step
    P["knee_lift"] = rng.uniform(0.03, 0.30)  # m
    P["heel_kick"] = rng.random() < 0.3
    P["arm_amp"] = 0.0 if rng.random() < 0.35 else rng.uniform(10, 40) * D2R
    P["elbow"] = rng.uniform(8, 30) * D2R
    P["sway"] = rng.uniform(0.0, 1.0)
    P["pause_p"] = rng.uniform(0.0, 0.25)
    P["side_w"] = rng.uniform(0.08, min(0.45, 0.24 * H))
    P["asym"] = rng.uniform(0.75, 1.25)  # lift ratio left/right
    P["jitter"] = rng.uniform(0.02, 0.15)
    P["drift"] = rng.uniform(0.002, 0.010)  # m per step
    P["side_p"] = rng.dirichlet([2.0, 1.5, 1.0])  # out_back, step_together, shuffle
    P["look_gain"] = rng.uniform(0.2, 0.5)
    return P


def _jit(P, rng, x):
    return x * float(np.clip(1.0 + P["jitter"] * rng.standard_normal(), 0.6, 1.5))


def _step_times(P, rng, speed=1.0):
    """Swing and double-support frames of one step."""
    T = _jit(P, rng, 1.0 / P["cadence"]) / speed
    sw = min(T * (1.0 - P["ds"]), P["swing_max"] / speed)
    sw = max(sw, 0.18)
    ds = max(T - sw, 0.07)
    return max(5, round(sw * FPS)), max(2, round(ds * FPS))


def _pause(P, rng):
    if rng.random() < P["pause_p"]:
        return round(rng.uniform(0.2, 1.0) * FPS)
    return 0


# ---------------------------------------------------------------- bouts
def plan_march(tl, rng, max_frames):
    P = tl.P
    heel = P["heel_kick"] and rng.random() < 0.8
    first = int(rng.integers(2))
    steps, tot, k = [], 0, 0
    pos = [tl.feet[0].copy(), tl.feet[1].copy()]
    while True:
        i = (first + k) % 2
        ns, nd = _step_times(P, rng)
        nd += _pause(P, rng)
        lift = P["knee_lift"] * (P["asym"] if i == 0 else 1.0 / P["asym"])
        lift = float(np.clip(_jit(P, rng, lift), 0.02, 0.34))
        shank = P["shank"]
        if heel:
            apex = lift + 0.10 * P["H"] * 0.5
            apex = min(apex, 1.2 * shank)
            phi = np.arccos(np.clip(1.0 - apex / shank, -1, 1))
            off = -0.8 * shank * np.sin(phi)
        else:
            apex = lift
            phi = np.arccos(np.clip(1.0 - lift / P["thigh"], -1, 1))
            off = 0.45 * P["thigh"] * np.sin(phi)
        h = tl.home(i)
        pos[i] = pos[i] + 0.35 * (h - pos[i]) + P["drift"] * rng.standard_normal(2)
        steps.append((i, pos[i].copy(), ns, nd, apex, off))
        tot += ns + (nd if k > 0 else 0)
        k += 1
        if tot + steps[-1][3] >= max_frames:
            break
    return steps, ("heel_kick" if heel else "march")


def _fit(steps, max_frames, unit):
    """Drop whole units from the end, or speed up, so that the bout fits."""

    def dur(s):
        return sum(x[2] + x[3] for x in s) - s[-1][3]

    while len(steps) > unit and dur(steps) > max_frames:
        steps = steps[:-unit]
    if dur(steps) > max_frames:
        f = max_frames / dur(steps)
        steps = [(i, p, max(4, int(ns * f)), max(2, int(nd * f)), a, o) for i, p, ns, nd, a, o in steps]
    return steps


def plan_side(tl, rng, d, max_frames):
    """d = +1 right, -1 left. Returns footstep list and pattern name."""
    P = tl.P
    lead, trail = (1, 0) if d > 0 else (0, 1)
    pat = ["out_back", "step_together", "shuffle"][int(rng.choice(3, p=P["side_p"]))]
    mech = pat if pat != "shuffle" else ("out_back" if rng.random() < 0.5 else "step_together")
    r = right_of(tl.theta)
    steps, tot, c = [], 0, tl.c.copy()
    width = P["side_w"]
    speed = 1.3 if pat == "shuffle" else 1.0
    if mech == "step_together":
        width = width * 0.8
        if np.linalg.norm(c + d * width * r) > ROOM_R:
            mech = "out_back"
    while True:
        w = float(np.clip(_jit(P, rng, width), 0.08, 0.45))
        ns1, nd1 = _step_times(P, rng, speed)
        ns2, nd2 = _step_times(P, rng, speed)
        nd1 += _pause(P, rng)
        nd2 += _pause(P, rng)
        if pat == "shuffle":
            a1, a2 = rng.uniform(0.003, 0.015), rng.uniform(0.003, 0.015)
        else:
            base = 0.35 * P["knee_lift"] + 0.02
            a1, a2 = _jit(P, rng, base), _jit(P, rng, 0.8 * base)
        drift = P["drift"] * rng.standard_normal(2)
        if mech == "out_back":
            hl = tl.home(lead, c)
            steps.append((lead, hl + d * w * r + drift, ns1, nd1, a1, 0.0))
            steps.append((lead, hl + 0.5 * drift, ns2, nd2, a2, 0.0))
        else:
            if np.linalg.norm(c + d * w * r) > ROOM_R:
                break
            c = c + d * w * r
            steps.append((lead, tl.home(lead, c) + drift, ns1, nd1, a1, 0.0))
            steps.append((trail, tl.home(trail, c), ns2, nd2, a2, 0.0))
        tot += ns1 + nd1 + ns2 + nd2
        if tot >= max_frames:
            break
    if not steps:  # cannot move sideways any further: out and back instead
        return plan_side_outback_min(tl, rng, d, lead), pat
    return steps, pat


def plan_side_outback_min(tl, rng, d, lead):
    P = tl.P
    r = right_of(tl.theta)
    ns1, nd1 = _step_times(P, rng)
    ns2, nd2 = _step_times(P, rng)
    hl = tl.home(lead)
    return [(lead, hl + d * P["side_w"] * r, ns1, nd1, 0.03, 0.0), (lead, hl, ns2, nd2, 0.03, 0.0)]


def run_bout(tl, rng, label, max_frames):
    if label == "forward":
        steps, pat = plan_march(tl, rng, max_frames)
        steps = _fit(steps, max_frames, 1)
    else:
        d = 1 if label == "right" else -1
        steps, pat = plan_side(tl, rng, d, max_frames)
        steps = _fit(steps, max_frames, 2)
    # weight onto the first stance foot before lift-off (still)
    i0 = steps[0][0]
    tl.hold(int(rng.uniform(0.25, 0.45) * FPS), w_to=(1.0 if i0 == 1 else 0.0))
    start = tl.t
    for k, (i, p, ns, nd, apex, off) in enumerate(steps):
        tl.swing(i, p, ns, apex, fwd_off=off)
        if k == len(steps) - 1:
            end = tl.t  # touch-down frame
            break
        nxt = steps[k + 1][0]
        w_next = 1.0 if nxt == 1 else 0.0
        if nxt == i:  # same foot again (out and back): share weight, then back
            h1 = max(1, nd // 2)
            tl.hold(h1, w_to=0.5)
            tl.hold(nd - h1, w_to=w_next)
        else:
            tl.hold(nd, w_to=w_next)
    tl.label[start : end + 1] = LABEL_ID[label]
    tl.tag[start : end + 1] = pat
    tl.bouts.append((label, pat, start, end))
    # the stance centre moves only with step-together patterns
    i_last, p_last = steps[-1][0], steps[-1][1]
    if label != "forward" and i_last != steps[0][0]:  # step-together: trailing foot closed up
        tl.c = p_last - (tl.home(i_last) - tl.c)
    tl.hold(1)
    return end


# ------------------------------------------------------ still behaviours
def min_frames(name):
    return int(
        FPS
        * {
            "turn": 2.0,
            "kneel": 4.5,
            "jump": 1.2,
            "squat": 1.8,
            "bow": 1.5,
            "wave": 1.2,
            "point": 1.2,
            "stretch": 1.5,
            "stand": 0.0,
        }.get(name, 0.6)
    )


def still(tl, rng, name, n):
    P, H = tl.P, tl.P["H"]
    a = tl.t
    ramp = int(rng.uniform(0.25, 0.6) * FPS)
    if name == "stand":
        tl.hold(n, w_to=float(np.clip(0.5 + 0.1 * rng.standard_normal(), 0.3, 0.7)))
    elif name == "weight_shift":
        k = np.arange(n)
        reps = max(1, int(n / FPS / rng.uniform(1.2, 3.0)))
        amp = rng.uniform(0.25, 0.45) * rng.choice([-1, 1])
        w = 0.5 + (tl.curw - 0.5) * (1 - mj(k / 8.0)) + amp * np.sin(2 * np.pi * reps * k / n / 2)
        tl.weights(np.clip(w, 0.05, 0.95))
    elif name in ("point", "wave"):
        side = "L" if rng.random() < 0.5 else "R"
        e = envelope(n, ramp)
        tl.add(name + side, a, e)
        if name == "point":
            tl.add("pt_elev", a, np.full(n, rng.uniform(35, 65) * D2R))
            tl.add("pt_az", a, np.full(n, rng.uniform(-30, 15) * D2R))
            tl.add("hyaw", a, e * rng.uniform(0, 20) * D2R * (1 if side == "L" else -1))
        else:
            tl.add("wave_f", a, np.full(n, rng.uniform(1.5, 3.0)))
        tl.hold(n, w_to=0.5)
    elif name == "look_around":
        k = 0
        yaw = np.zeros(n)
        pitch = np.zeros(n)
        cur, curp = 0.0, 0.0
        while k < n:
            seg = int(rng.uniform(0.6, 1.5) * FPS)
            tgt = rng.uniform(-75, 75) * D2R if k + seg < n - 10 else 0.0
            tgp = rng.uniform(-20, 25) * D2R if k + seg < n - 10 else 0.0
            s = mj((np.arange(min(seg, n - k)) + 1.0) / (0.6 * seg))
            yaw[k : k + seg] = cur + (tgt - cur) * s
            pitch[k : k + seg] = curp + (tgp - curp) * s
            cur, curp, k = tgt, tgp, k + seg
        yaw *= envelope(n, 6)
        pitch *= envelope(n, 6)
        tl.add("hyaw", a, yaw)
        tl.add("hpitch", a, pitch)
        tl.add("tyaw", a, P["look_gain"] * yaw)
        tl.hold(n, w_to=0.5)
    elif name == "turn":
        turn(tl, rng, n)
    elif name == "stretch":
        e = envelope(n, int(0.5 * FPS))
        tl.add("stretch", a, e)
        tl.add("pitch", a, -e * rng.uniform(0, 8) * D2R)
        tl.hold(n, w_to=0.5)
    elif name == "bow":
        e = envelope(n, int(0.5 * FPS))
        tl.add("pitch", a, e * rng.uniform(15, 35) * D2R)
        tl.add("hpitch", a, e * rng.uniform(5, 20) * D2R)
        tl.add("pel_back", a, e * 0.02 * H)
        tl.hold(n, w_to=0.5)
    elif name == "lean":
        e = envelope(n, ramp)
        p, r = rng.uniform(-8, 15) * D2R, rng.uniform(-10, 10) * D2R
        tl.add("pitch", a, e * p)
        tl.add("roll", a, e * r)
        tl.hold(n, w_to=float(np.clip(0.5 - 2.0 * r, 0.2, 0.8)), ramp=ramp)
    elif name == "squat":
        e = envelope(n, int(rng.uniform(0.6, 1.0) * FPS))
        depth = rng.uniform(0.15, 0.45) * (P["thigh"] + P["shank"])
        tl.add("zmod", a, -e * depth)
        tl.add("pel_back", a, e * 0.45 * depth)
        tl.add("pitch", a, e * (15 + 40 * depth / (P["thigh"] + P["shank"])) * D2R)
        tl.add("armfwd", a, e * rng.uniform(0.3, 1.0))
        tl.hold(n, w_to=0.5)
    elif name == "kneel":
        kneel(tl, rng, n)
    elif name == "tiptoe":
        e = envelope(n, int(0.35 * FPS))
        r = rng.uniform(0.03, 0.08)
        tl.hold(n, w_to=0.5)
        tl.ank[a : a + n, :, 2] += (r * e)[:, None]
        tl.add("zmod", a, r * e)
    elif name == "jump":
        jump(tl, rng, n)
    elif name == "sway":
        k = np.arange(n)
        f = rng.uniform(0.4, 1.0)
        ph = rng.uniform(0, 2 * np.pi)
        e = envelope(n, 10)
        sw = np.sin(2 * np.pi * f * k / FPS + ph) * e
        tl.add("roll", a, sw * rng.uniform(2, 6) * D2R)
        tl.add("zmod", a, -0.5 * rng.uniform(0, 0.04) * (1 - np.cos(4 * np.pi * f * k / FPS)) * e)
        tl.add("hyaw", a, sw * rng.uniform(0, 15) * D2R)
        tl.add("tyaw", a, sw * rng.uniform(0, 10) * D2R)
        tl.weights(
            np.clip(0.5 - rng.uniform(0.15, 0.4) * sw + (tl.curw - 0.5) * (1 - mj(k / 8.0)), 0.05, 0.95)
        )
    else:
        raise ValueError(name)
    if tl.t < a + n:
        tl.hold(a + n - tl.t, w_to=0.5)
    tl.tag[a : tl.t] = "" if name == "stand" else name


def turn(tl, rng, n):
    P = tl.P
    ns, nd = _step_times(P, rng, speed=1.2)
    ns, nd = min(ns, int(0.6 * FPS)), min(nd, int(0.3 * FPS))
    per = 2 * (ns + nd)
    max_inc = max(1, (n - 10) // per)
    total = rng.uniform(30, 180) * D2R
    inc = int(np.clip(np.ceil(total / (rng.uniform(35, 60) * D2R)), 1, max_inc))
    total = min(total, inc * 60 * D2R)
    sgn = 1.0 if rng.random() < 0.5 else -1.0  # +: counter-clockwise = to the left
    first = 0 if sgn > 0 else 1
    th0 = tl.theta
    for j in range(inc):
        th = th0 + sgn * total * (j + 1) / inc
        for i in (first, 1 - first):
            tl.hold(nd, w_to=(1.0 if i == 0 else 0.0))
            tl.swing(i, tl.home(i, theta=th), ns, rng.uniform(0.02, 0.06), yaw_to=th)
        tl.theta = th
    tl.hold(2, w_to=0.5)


def kneel(tl, rng, n):
    P, H = tl.P, tl.P["H"]
    f = fwd_of(tl.theta)
    b = int(rng.integers(2))  # the foot that goes back (knee on floor)
    fr = 1 - b
    ns = int(0.55 * FPS)
    hb, hf = tl.home(b), tl.home(fr)
    a0 = tl.t
    tl.hold(int(0.3 * FPS), w_to=(1.0 if fr == 0 else 0.0))
    tl.swing(fr, hf + 0.10 * H * f, ns, 0.05)
    tl.hold(int(0.25 * FPS), w_to=(1.0 if fr == 0 else 0.0))
    tl.swing(b, hb - 0.20 * H * f, ns, 0.04, z_to=P["ha"] + 0.025 * H)
    rest = n - (tl.t - a0) - 2 * ns - int(0.55 * FPS)
    down = max(10, rest)
    e = envelope(down, int(0.7 * FPS))
    z_nom = P["ha"] + 0.99 * (P["thigh"] + P["shank"])
    tl.add("zmod", tl.t, -e * (z_nom - (0.03 * H + P["thigh"])))
    tl.add("pitch", tl.t, e * 8 * D2R)
    tl.hold(down, w_to=0.55 if fr == 0 else 0.45, ramp=int(0.5 * FPS))
    tl.hold(int(0.25 * FPS), w_to=(1.0 if fr == 0 else 0.0))
    tl.swing(b, hb, ns, 0.05, z_to=P["ha"])
    tl.hold(int(0.3 * FPS), w_to=(1.0 if b == 0 else 0.0))
    tl.swing(fr, hf, ns, 0.04)


def jump(tl, rng, n):
    k = int(rng.integers(1, 4))
    a0 = tl.t
    for _ in range(k):
        h = rng.uniform(0.04, 0.14)
        nf = max(4, round(2 * np.sqrt(2 * h / 9.81) * FPS))
        dip = int(0.3 * FPS)
        if tl.t + 2 * dip + nf > a0 + n:
            break
        e = envelope(dip, dip // 2)
        tl.add("zmod", tl.t, -e * rng.uniform(0.03, 0.08))
        tl.hold(dip, w_to=0.5)
        tl.flight(nf, h)
        tl.add("zmod", tl.t, -e * rng.uniform(0.03, 0.08))
        tl.hold(dip)


# --------------------------------------------------------------- planner
def plan_file(P, rng, T):
    theta = rng.uniform(-np.pi, np.pi)
    ang, rad = rng.uniform(0, 2 * np.pi), ROOM_R * np.sqrt(rng.random()) * 0.8
    tl = Timeline(P, T, [rad * np.cos(ang), rad * np.sin(ang)], theta)
    short = T < 40 * FPS
    dirs = []
    tl.hold(int(rng.uniform(0.3, 0.8 if short else 3.0) * FPS), w_to=0.5)
    n_bouts = 0
    gap = (1.5, 2.0) if short else (1.5, 6.0)
    while True:
        if not dirs:
            dirs = list(rng.permutation(["forward", "left", "right"]))
        remaining = T - tl.t
        tail = int(0.5 * FPS)
        if remaining < int(1.4 * FPS) + tail:
            break
        if short:
            left_bouts = max(1, 3 - n_bouts)
            budget = (remaining - tail - (left_bouts - 1) * int(1.5 * FPS)) / left_bouts
            dur = min(rng.uniform(1.0, 10.0) * FPS, budget - 0.45 * FPS)
        else:
            dur = min(rng.uniform(1.0, 10.0) * FPS, remaining - tail - 0.45 * FPS)
        if dur < 0.9 * FPS:
            break
        run_bout(tl, rng, dirs.pop(0), int(dur))
        n_bouts += 1
        gl = int(rng.uniform(*gap) * FPS)
        still_stretch(tl, rng, gl)
        if tl.t >= T:
            break
    if tl.t < T:
        still_stretch(tl, rng, T - tl.t)
    return tl


def still_stretch(tl, rng, n):
    if n >= min_frames("kneel") and rng.random() < 0.12:
        still(tl, rng, "kneel", int(n))
        return
    k = int(rng.integers(1, 4))
    k = max(1, min(k, n // int(0.6 * FPS)))
    cuts = np.sort(rng.uniform(0, 1, k - 1))
    parts = np.diff(np.concatenate([[0], np.round(cuts * n), [n]])).astype(int)
    for m in parts:
        if m <= 0:
            continue
        ok = [i for i, b in enumerate(STILL_BEHAVIOURS) if min_frames(b) <= m]
        p = STILL_P[ok] / STILL_P[ok].sum()
        name = STILL_BEHAVIOURS[ok[int(rng.choice(len(ok), p=p))]]
        still(tl, rng, name, int(m))
