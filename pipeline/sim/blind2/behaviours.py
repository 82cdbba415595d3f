"""The blind2 still behaviours: gestures, looking around, weight shifts, squats, bows, turns.

Each behaviour blends its own posture channels in (raised-cosine ramps, or its own curve) over a
window of frames that starts at the planner's current frame, tags that window and moves the
planner past it; it does nothing if it would not fit in ``room`` frames. All of them keep the
feet down except the turn, which pivots on the spot in ⌈Δ/(35–55°)⌉ steps plus a closing step
(opening with the foot on the turning side), with the head and trunk leading. They are labelled
``still``. The order of the random draws inside each is part of the generator's output.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from pipeline.sim.blind2.geometry import right_vec
from pipeline.sim.blind2.profiles import DEG, FPS, envelope, frames, piecewise_smooth
from pipeline.sim.blind2.truth import STILL_BEHAVIOURS, Turn

if TYPE_CHECKING:
    from pipeline.sim.blind2.script import Planner


def wave(p: Planner, room: int) -> None:
    """One arm raised, the elbow oscillating at 1.5–3 Hz."""
    r = p.rng
    n = p.duration(room, 2.0, 5.0)
    if n < frames(1.5):
        return
    i0 = p.cur
    s = "L" if r.random() < 0.5 else "R"
    sg = 1 if s == "L" else -1
    w = envelope(n, frames(r.uniform(0.4, 0.8)), frames(r.uniform(0.4, 0.8)))
    t = np.arange(n) / FPS
    e0, amp, f = r.uniform(70, 100) * DEG, r.uniform(15, 30) * DEG, r.uniform(1.5, 3.0)
    ch = p.channels
    ch.blend("a" + s, i0, r.uniform(55, 100) * DEG, w)
    ch.blend("b" + s, i0, r.uniform(100, 150) * DEG, w)
    ch.blend("e" + s, i0, e0 + amp * np.sin(2 * np.pi * f * t), w)
    ch.blend("r" + s, i0, r.uniform(-10, 30) * DEG, w)
    ch.blend("hyaw", i0, sg * r.uniform(0, 20) * DEG, w)
    ch.blend("troll", i0, -sg * r.uniform(0, 4) * DEG, w)
    p.tag(i0, n, "wave")


def point(p: Planner, room: int) -> None:
    """A straight arm pointing, sometimes re-aimed halfway; the head and trunk turn toward it."""
    r = p.rng
    n = p.duration(room, 2.0, 4.5)
    if n < frames(1.5):
        return
    i0 = p.cur
    s = "L" if r.random() < 0.5 else "R"
    sg = 1 if s == "L" else -1
    w = envelope(n, frames(r.uniform(0.4, 0.8)), frames(r.uniform(0.4, 0.8)))
    al = [r.uniform(-20, 70), r.uniform(-20, 70)]
    be = [r.uniform(70, 105), r.uniform(70, 105)]
    if r.random() < 0.6:
        al[1], be[1] = al[0], be[0]
    m = n // 2
    alc = piecewise_smooth(n, [(0, al[0]), (m - 3, al[0]), (m + 3, al[1]), (n, al[1])], 2) * DEG
    bec = piecewise_smooth(n, [(0, be[0]), (m - 3, be[0]), (m + 3, be[1]), (n, be[1])], 2) * DEG
    ch = p.channels
    ch.blend("a" + s, i0, alc, w)
    ch.blend("b" + s, i0, bec, w)
    ch.blend("e" + s, i0, r.uniform(0, 15) * DEG, w)
    ch.blend("r" + s, i0, r.uniform(-20, 20) * DEG, w)
    ch.blend("hyaw", i0, sg * alc * r.uniform(0.4, 0.8), w)
    ch.blend("ttwist", i0, sg * alc * r.uniform(0.05, 0.2), w)
    ch.blend("hpitch", i0, -(bec - 90 * DEG) * 0.5, w)
    p.tag(i0, n, "point")


def look_around(p: Planner, room: int) -> None:
    """2–4 head-yaw excursions of 25–75°, the trunk following at 15–40 %."""
    r = p.rng
    n = p.duration(room, 3.0, 6.5)
    if n < frames(2.0):
        return
    i0 = p.cur
    k = int(r.integers(2, 5))
    knots: list[tuple[float, float]] = [(0, 0.0)]
    sg = 1 if r.random() < 0.5 else -1
    for j in range(k):
        knots.append((int(n * (j + 0.6) / (k + 0.5)), sg * r.uniform(25, 75)))
        knots.append((int(n * (j + 1.0) / (k + 0.5)), knots[-1][1]))
        sg = -sg
    knots.append((n, 0.0))
    hy = piecewise_smooth(n, knots, 4) * DEG
    pitch_knots: list[tuple[float, float]] = [
        (0, 0),
        *[(int(n * (j + 1) / (k + 1)), r.uniform(-20, 15)) for j in range(k)],
        (n, 0),
    ]
    hp = piecewise_smooth(n, pitch_knots, 4) * DEG
    w = envelope(n, frames(0.3), frames(0.3))
    ch = p.channels
    ch.blend("hyaw", i0, hy, w)
    ch.blend("hpitch", i0, hp, w)
    ch.blend("ttwist", i0, hy * r.uniform(0.15, 0.4), w)
    ch.blend("pyaw", i0, hy * r.uniform(0.0, 0.1), w)
    p.tag(i0, n, "look-around")


def reach(p: Planner, room: int) -> None:
    """One or both arms reaching; the trunk leans in for forward reaches, the head tilts up for high ones."""
    r = p.rng
    n = p.duration(room, 2.0, 4.5)
    if n < frames(1.5):
        return
    i0 = p.cur
    which = str(r.choice(["L", "R", "LR"]))
    w = envelope(n, frames(r.uniform(0.5, 1.0)), frames(r.uniform(0.5, 1.0)))
    be = r.uniform(50, 145)
    al = r.uniform(-10, 60)
    ch = p.channels
    for s in which:
        ch.blend("a" + s, i0, (al + r.uniform(-5, 5)) * DEG, w)
        ch.blend("b" + s, i0, (be + r.uniform(-5, 5)) * DEG, w)
        ch.blend("e" + s, i0, r.uniform(5, 35) * DEG, w)
    if be < 110:
        ch.blend("tpitch", i0, r.uniform(3, 22) * DEG, w)
        ch.blend("pdy", i0, -r.uniform(0.0, 0.04), w)
    else:
        ch.blend("tpitch", i0, r.uniform(-6, 2) * DEG, w)
        ch.blend("hpitch", i0, -r.uniform(5, 25) * DEG, w)
    if which != "LR":
        sg = 1 if which == "L" else -1
        ch.blend("ttwist", i0, -sg * r.uniform(0, 12) * DEG, w)
    p.tag(i0, n, "reach")


def stretch(p: Planner, room: int) -> None:
    """Both arms overhead with the trunk extended, sometimes a lateral bend."""
    r = p.rng
    n = p.duration(room, 2.5, 5.0)
    if n < frames(2.0):
        return
    i0 = p.cur
    w = envelope(n, frames(r.uniform(0.6, 1.1)), frames(r.uniform(0.6, 1.1)))
    ch = p.channels
    for s in "LR":
        ch.blend("a" + s, i0, r.uniform(5, 40) * DEG, w)
        ch.blend("b" + s, i0, r.uniform(150, 178) * DEG, w)
        ch.blend("e" + s, i0, r.uniform(0, 40) * DEG, w)
        ch.blend("r" + s, i0, 0.0, w)
    ch.blend("tpitch", i0, -r.uniform(3, 12) * DEG, w)
    ch.blend("hpitch", i0, -r.uniform(5, 25) * DEG, w)
    if r.random() < 0.4:
        m = n // 2
        lb = r.uniform(8, 20) * (1 if r.random() < 0.5 else -1)
        knots = [(0, 0), (m - frames(0.5), lb), (m + frames(0.5), -lb), (n, 0)]
        rc = piecewise_smooth(n, knots, 4) * DEG
        ch.blend("troll", i0, rc, w)
    p.tag(i0, n, "stretch")


def bow(p: Planner, room: int) -> None:
    """The trunk pitched 20–70° with the hips back, the head down and the arms hanging."""
    r = p.rng
    rin = frames(r.uniform(0.6, 1.2))
    hold = frames(r.uniform(0.3, 1.5))
    rout = frames(r.uniform(0.6, 1.2))
    n = rin + hold + rout
    if n > room:
        return
    i0 = p.cur
    w = envelope(n, rin, rout)
    pitch = r.uniform(20, 70) * DEG
    ch = p.channels
    ch.blend("tpitch", i0, pitch, w)
    ch.blend("hpitch", i0, r.uniform(0, 20) * DEG, w)
    ch.blend("pdy", i0, -r.uniform(0.25, 0.45) * p.body.trunk_m * math.sin(pitch), w)
    for s in "LR":
        ch.blend("b" + s, i0, pitch * r.uniform(0.8, 1.0), w)
        ch.blend("e" + s, i0, r.uniform(5, 20) * DEG, w)
        ch.blend("a" + s, i0, r.uniform(0, 10) * DEG, w)
    p.tag(i0, n, "bow")


def cross_arms(p: Planner, room: int) -> None:
    """Both forearms across the chest, held for 3–6 s."""
    r = p.rng
    n = p.duration(room, 3.0, 6.0)
    if n < frames(2.0):
        return
    i0 = p.cur
    w = envelope(n, frames(r.uniform(0.6, 1.0)), frames(r.uniform(0.6, 1.0)))
    ch = p.channels
    for s in "LR":
        ch.blend("a" + s, i0, r.uniform(-20, 0) * DEG, w)
        ch.blend("b" + s, i0, r.uniform(35, 50) * DEG, w)
        ch.blend("e" + s, i0, r.uniform(95, 120) * DEG, w)
        ch.blend("r" + s, i0, r.uniform(70, 95) * DEG, w)
    p.tag(i0, n, "cross-arms")


def weight_shift(p: Planner, room: int) -> None:
    """2–5 shifts of the pelvis over one foot and then the other (20–45 % of the stance width)."""
    r = p.rng
    k = int(r.integers(2, 6))
    knots: list[tuple[float, float]] = [(0, 0.0)]
    t = 0
    sg = 1 if r.random() < 0.5 else -1
    for _ in range(k):
        t += frames(r.uniform(0.35, 0.8))
        v = sg * r.uniform(0.2, 0.45)
        knots.append((t, v))
        t += frames(r.uniform(0.3, 1.4))
        knots.append((t, v))
        sg = -sg
    t += frames(r.uniform(0.35, 0.8))
    knots.append((t, 0.0))
    n = t + 1
    if n > room:
        return
    i0 = p.cur
    ws = piecewise_smooth(n, knots, 3)
    w = np.ones(n)
    ch = p.channels
    ch.blend("ws", i0, ws, w)
    ch.blend("proll", i0, -ws * r.uniform(0.08, 0.2), w)
    ch.blend("troll", i0, ws * r.uniform(0.0, 0.08), w)
    p.tag(i0, n, "weight-shift")


def squat(p: Planner, room: int) -> None:
    """1–2 squats: the pelvis drops 15–45 cm (scaled by height) and moves back, the trunk pitches."""
    r = p.rng
    reps = 1 if r.random() < 0.7 else 2
    D = r.uniform(0.15, 0.45) * p.body.height_m / 1.75
    knots: list[tuple[float, float]] = [(0, 0.0)]
    t = 0
    for _ in range(reps):
        t += frames(r.uniform(0.8, 1.5))
        knots.append((t, 1.0))
        t += frames(r.uniform(0.3, 1.5))
        knots.append((t, 1.0))
        t += frames(r.uniform(0.8, 1.5))
        knots.append((t, 0.0))
    n = t + 1
    if n > room:
        return
    i0 = p.cur
    x = piecewise_smooth(n, knots, 3)
    x = 0.5 - 0.5 * np.cos(np.pi * np.clip(x, 0, 1))
    w = np.ones(n)
    ch = p.channels
    ch.blend("drop", i0, D * x, w)
    ch.blend("pdy", i0, -r.uniform(0.3, 0.6) * D * x, w)
    tp = (r.uniform(10, 35) * D / 0.45 + 5) * DEG
    ch.blend("tpitch", i0, tp * x, x)
    ch.blend("hpitch", i0, -0.5 * tp * x, x)
    for s in "LR":
        ch.blend("b" + s, i0, r.uniform(30, 90) * DEG, x)
        ch.blend("e" + s, i0, r.uniform(10, 60) * DEG, x)
        ch.blend("a" + s, i0, r.uniform(0, 15) * DEG, x)
    p.tag(i0, n, "squat")


def turn(p: Planner, room: int) -> None:
    """Turn 45–180° on the spot in pivot steps about the body centre; the head and trunk lead."""
    r = p.rng
    band = p.counts.turn_band  # magnitude band: 45–90°, 90–135° or 135–180°
    lo = 45 + 45 * (band % 3)
    dy = r.uniform(lo, lo + 45) * DEG * (1 if r.random() < 0.5 else -1)
    nst = math.ceil(abs(dy) / (r.uniform(35, 55) * DEG))
    c = p.feet.centre()
    y0 = p.feet.facing()
    sw = float(np.clip(p.body.stance_width_m * r.uniform(0.85, 1.1), 0.1, 0.32))
    snap = p.feet.snapshot()
    i0 = p.cur
    t = i0 + frames(r.uniform(0.2, 0.4))
    foot = 0 if dy > 0 else 1  # open with the foot on the turning side
    yaws = y0 + dy * np.arange(1, nst + 1) / nst
    steps = [(foot if k % 2 == 0 else 1 - foot, float(yaws[k])) for k in range(nst)]
    steps.append((1 - steps[-1][0], float(yaws[-1])))
    first_a = t
    last_b = t
    for f, yk in steps:
        side = -1 if f == 0 else 1
        p1 = c + right_vec(yk) * side * sw / 2 + r.normal(0, 0.006, 2)
        a = t
        last_b = p.feet.swing(
            f,
            a,
            frames(r.uniform(0.3, 0.6)),
            p1,
            y1=yk,
            lift=r.uniform(0.01, 0.04),
            style="lift",
            skew=r.uniform(0.8, 1.2),
        )
        t = last_b + frames(r.uniform(0.034, 0.3))
    end = last_b + frames(r.uniform(0.2, 0.4))
    n = end - i0
    if end > p.n_frames - frames(0.5) or n > room:
        p.feet.restore(snap)
        return
    sg = 1 if dy > 0 else -1
    w = envelope(n, frames(0.25), frames(0.35))
    p.channels.blend("hyaw", i0, sg * r.uniform(8, 25) * DEG, w)
    p.channels.blend("ttwist", i0, sg * r.uniform(3, 10) * DEG, w)
    # The original generator advances the band by the number of pivot steps of this turn (its
    # step loop reused the band's variable), not by one: kept, as it is part of the output.
    p.counts.turn_band = len(steps)
    p.turns.append(Turn(i0, end - 1, first_a, last_b, dy, len(steps)))
    p.tag(i0, n, "turn")


BEHAVIOURS: dict[str, Callable[[Planner, int], None]] = dict(
    zip(
        STILL_BEHAVIOURS,
        (wave, point, look_around, reach, stretch, bow, cross_arms, weight_shift, squat, turn),
        strict=True,
    )
)
