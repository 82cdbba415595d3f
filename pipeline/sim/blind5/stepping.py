"""Stepping bouts (locomotion layer): march in place and the sideways step kinds."""

import numpy as np

from pipeline.sim.blind5.timeline import fwd_vec, right_vec

ROOM = 0.45  # travelling bouts keep the stance centre within this radius of the origin
FOOT_ROOM = 0.72  # no ankle ever leaves this radius
SIDE_KINDS = ["side-step-out-back", "step-together", "step-touch", "shuffle"]


def room_along(c, d, radius=ROOM):
    """Largest t >= 0 with |c + t d| <= radius."""
    bq = float(c @ d)
    disc = bq * bq - float(c @ c - radius**2)
    return 0.0 if disc < 0 else max(0.0, -bq + np.sqrt(disc))


def _params(kind, rng, st):
    p = {
        "pauses": rng.random() < 0.35,
        "jit": st["jitter"],
        "asym_l": st["asym_lift"],
        "asym_t": st["asym_time"],
        "sway": st["sway"] * rng.uniform(0.6, 1.4),
        "width": st["width"] * rng.uniform(0.9, 1.15),
    }
    if kind == "march":
        cad = (
            rng.uniform(0.5, 2.6)
            if rng.random() < 0.3
            else np.clip(st["cadence"] * np.exp(rng.normal(0, 0.2)), 0.5, 2.6)
        )
        p["period"] = 1.0 / cad
        hi = 0.30 if cad < 1.8 else 0.18
        p["lift"] = (
            rng.uniform(0.03, hi)
            if rng.random() < 0.3
            else np.clip(st["lift"] * np.exp(rng.normal(0, 0.25)), 0.03, hi)
        )
        p["duty"] = rng.uniform(0.55, 0.8)
        p["arm"] = 0.0 if rng.random() < 0.25 else min(35.0, st["arm"] * rng.uniform(0.6, 1.4))
        p["slide"] = rng.uniform(0.0, 0.03) if rng.random() < 0.4 else rng.uniform(0.0, 0.008)
        p["travel"] = rng.uniform(-0.01, 0.02) if rng.random() < 0.4 else 0.0
        p["roll"] = rng.uniform(1.0, 5.0)
        p["first"] = int(rng.integers(2))
    else:
        lo, hi = {"side-step-out-back": (0.08, 0.45), "shuffle": (0.10, 0.25)}.get(kind, (0.15, 0.40))
        p["d"] = (lo, hi, rng.uniform(lo, hi))
        p["lift"] = rng.uniform(0.003, 0.03) if kind == "shuffle" else rng.uniform(0.03, 0.12)
        sp = st["speed"] * rng.uniform(0.8, 1.25)
        p["sw"] = (0.25 if kind == "shuffle" else 0.38) * sp
        p["gap"] = (0.06, 0.35) if kind == "shuffle" else (0.08, 0.5)
    return p


def _jit(rng, p, x, scale=1.0):
    return x * (1.0 + np.clip(rng.normal(0.0, p["jit"] * scale), -0.35, 0.35))


def _gap(rng, p, lo, hi):
    if p["pauses"] and rng.random() < 0.3:
        return rng.uniform(0.2, 1.0), True
    return min(rng.uniform(lo, hi), 0.8), False


def _march_group(tl, p, rng, k, centre):
    _st, th = tl.style, tl.heading
    foot = (p["first"] + k) % 2
    sgn = -1.0 if foot == 0 else 1.0
    tr = p["travel"] * rng.uniform(0.5, 1.0)
    nc = centre + fwd_vec(th) * tr
    if np.linalg.norm(nc) > ROOM:
        nc = centre
    B = (
        nc
        + right_vec(th) * sgn * p["width"] / 2
        + fwd_vec(th) * rng.uniform(-p["slide"], p["slide"])
        + right_vec(th) * rng.normal(0.0, 0.006)
    )
    apex = np.clip(_jit(rng, p, p["lift"] * (1 + sgn * p["asym_l"])), 0.03, 0.30)
    sw = _jit(rng, p, p["period"] * p["duty"] * (1 + sgn * p["asym_t"]), 0.7)
    sw = max(sw, p["period"] - 0.75)
    base = max(p["period"] - sw, 1.0 / tl.fps)
    gap, pause = _gap(rng, p, 0.85 * base, 1.15 * base)
    step = dict(
        foot=foot,
        B=B,
        sw=sw,
        gap=gap,
        pause=pause,
        zkeys=((0.0, 0.0), (rng.uniform(0.4, 0.55), apex), (1.0, 0.0)),
    )
    return [step], nc


def _side_group(tl, kind, p, rng, sgn, centre):
    th = tl.heading
    r, fw = right_vec(th) * sgn, fwd_vec(th)
    lead = 1 if sgn > 0 else 0
    trail = 1 - lead
    lo, hi, mean = p["d"]
    d = float(np.clip(mean * np.exp(rng.normal(0, 0.15)), lo, hi))
    if kind != "side-step-out-back":
        d = min(d, room_along(centre, r))
        if d < 0.07:
            return None, centre
    d = min(d, room_along(tl.feet[lead], r, FOOT_ROOM) - 0.03)
    hk = ((0.0, 0.0), (0.12, 0.0), (0.88, 1.0), (1.0, 1.0))

    def z(apex):
        return ((0.0, 0.0), (rng.uniform(0.4, 0.55), apex), (1.0, 0.0))

    def lift():
        return max(0.002, _jit(rng, p, p["lift"]))

    feet = tl.feet
    out = feet[lead] + r * d + fw * rng.normal(0.0, 0.012)
    g1, ps1 = _gap(rng, p, *p["gap"])
    g2, ps2 = _gap(rng, p, *p["gap"])
    s1 = dict(foot=lead, B=out, sw=_jit(rng, p, p["sw"]), gap=g1, pause=ps1, hkeys=hk, zkeys=z(lift()))
    if kind == "side-step-out-back":
        back = feet[lead] + fw * rng.normal(0.0, 0.008) + r * rng.normal(0.0, 0.008)
        s2 = dict(foot=lead, B=back, sw=_jit(rng, p, p["sw"]), gap=g2, pause=ps2, hkeys=hk, zkeys=z(lift()))
        return [s1, s2], centre
    w = p["width"] * (rng.uniform(0.55, 0.85) if kind == "step-touch" else rng.uniform(0.85, 1.1))
    land = out - r * w + fw * rng.normal(0.0, 0.01)
    s2 = dict(foot=trail, B=land, sw=_jit(rng, p, p["sw"]), gap=g2, pause=ps2, hkeys=hk, zkeys=z(lift()))
    if kind == "step-touch":  # come in, tap without weight, small re-lift, then take weight
        move, tap, rel = _jit(rng, p, p["sw"]), rng.uniform(0.1, 0.25), rng.uniform(0.15, 0.3)
        tot = move + tap + rel
        a, b2 = move / tot, (move + tap) / tot
        s2.update(
            sw=tot,
            hkeys=((0.0, 0.0), (0.1 * a, 0.0), (a, 1.0), (1.0, 1.0)),
            zkeys=(
                (0.0, 0.0),
                (0.5 * a, lift()),
                (a, 0.0),
                (b2, 0.0),
                ((b2 + 1) / 2, rng.uniform(0.008, 0.03)),
                (1.0, 0.0),
            ),
        )
    return [s1, s2], (out + land) / 2


def run_bout(tl, start, end, label, rng):
    """Fill frames [start, end) with one stepping bout; returns the last touch-down frame."""
    _fps, th = tl.fps, tl.heading
    centre = tl.feet.mean(0)
    if label == "forward":
        kind = "march"
    else:
        sgn = -1.0 if label == "left" else 1.0
        kind = SIDE_KINDS[rng.choice(4, p=[0.3, 0.25, 0.25, 0.2])]
        if kind != "side-step-out-back" and room_along(centre, right_vec(th) * sgn) < 0.12:
            kind = "side-step-out-back"
    p = _params(kind, rng, tl.style)
    f, last, k = start, None, 0
    arm, roll, shift, pauses, spans = [], [], [], [], []
    while True:
        if kind == "march":
            steps, nc = _march_group(tl, p, rng, k, centre)
        else:
            steps, nc = _side_group(tl, kind, p, rng, sgn, centre)
            if steps is None:  # no room left to travel: keep stepping out and back
                kind = "side-step-out-back"
                p["d"] = (0.08, 0.45, min(p["d"][2], 0.25))
                continue
        fr = [(max(2, tl.fr(s["sw"])), max(1, tl.fr(s["gap"]))) for s in steps]
        need = sum(a + g for a, g in fr) - fr[-1][1]
        if f + need > end - 1:
            if last is not None:
                break
            scale = (end - 1 - f) / need
            fr = [(max(2, int(a * scale)), max(1, int(g * scale))) for a, g in fr]
        spans.append((f, kind))
        for s, (swf, gf) in zip(steps, fr, strict=False):
            L, D = f, f + swf
            foot = s["foot"]
            stance = tl.feet[1 - foot]
            v = stance - tl.feet.mean(0)
            v = v / max(np.linalg.norm(v), 1e-6) * p["sway"]
            if last is None:
                shift.append((L - tl.fr(0.25), np.zeros(2)))
            shift += [(L, v), (D - 1, 0.7 * v)]
            tl.swing(foot, L, D, s["B"], None, s.get("hkeys", ((0.0, 0.0), (1.0, 1.0))), s["zkeys"])
            if kind == "march":
                sg = -1.0 if foot == 0 else 1.0
                apex_f = L + 0.5 * swf
                arm.append((apex_f, sg * p["arm"]))  # left arm forward when right leg lifts
                roll.append((apex_f, -sg * p["roll"]))
            last, f = D, D + gf
            if s["pause"]:
                pauses.append((D + 1, f))
                shift.append(((D + f) / 2, np.zeros(2)))
        centre = nc
        k += 1
    shift.append((last + tl.fr(0.3), np.zeros(2)))
    tl.shift_keys += shift
    if arm:
        a0, a1 = start - tl.fr(0.2), last + tl.fr(0.3)
        t = [a0] + [a[0] for a in arm] + [a1]
        v = np.array([0.0] + [a[1] for a in arm] + [0.0])
        tl.add_frame_keys("la_flex", t, v, 0.2)
        tl.add_frame_keys("ra_flex", t, -0.8 * v, 0.2)
        tl.add_frame_keys("la_elb", t, 0.4 * np.abs(v), 0.2)
        tl.add_frame_keys("ra_elb", t, 0.4 * np.abs(v), 0.2)
        rv = np.array([0.0] + [x[1] for x in roll] + [0.0])
        tl.add_frame_keys("pel_roll", t, rv, 0.2)
        tl.add_frame_keys("sp_roll", t, -0.8 * rv, 0.2)
        tl.add_frame_keys("pel_yaw", t, 0.1 * v, 0.2)
    tl.labels[start : last + 1] = label
    for (a, kd), (b, _) in zip(spans, [*spans[1:], (last + 1, None)], strict=False):
        tl.tags[a : min(b, last + 1)] = kd
    for a, b in pauses:
        tl.tags[a:b] = "pause"
    return last
