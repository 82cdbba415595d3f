"""The blind2 stepping bouts: marching in place and the three kinds of side step.

* march: cadence 0.5–2.6 steps/s, knee lift 3–30 cm, shank angle 5–40°, ±15 % jitter per step,
  ±20 % left/right asymmetry, swing 50–85 % of the step period; some bouts pause, travel a little,
  drift sideways or let the stance foot slide; the arms counter-swing (35 % of bouts do not).
* side-step-out-back: the side's foot steps out 8–45 cm and back, 2–6 times.
* step-together: the side's foot steps out, the other follows to restore the stance width; the
  body travels sideways (at most 1.3 m, and it stays within ±1.35 m of the room centre).
* shuffle: step-together with 8–20 cm steps, a barely visible lift and quick swings.

Inside a bout every both-feet-down gap is at most MAX_GAP_S, so its label never breaks. A plan
returns the bout and a function that blends its posture channels in, which the planner calls only
if it keeps the bout (its random draws come then).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from pipeline.sim.blind2.geometry import facing_vec, right_vec
from pipeline.sim.blind2.profiles import DEG, FPS, envelope, frames
from pipeline.sim.blind2.truth import FOOT_NAMES, Bout

if TYPE_CHECKING:
    from pipeline.sim.blind2.script import Planner

ROOM_HALF = 1.35  # m: a person stays within ±ROOM_HALF of the room centre (x and y)
MAX_GAP_S = 0.97  # s: the longest both-feet-down time between two steps of one bout


@dataclass(frozen=True, slots=True)
class BoutPlan:
    """A planned bout, and what commits its posture channels (drawn only if the bout is kept)."""

    bout: Bout
    apply_channels: Callable[[], None]


def gap_s(rng: np.random.Generator, base_s: float, pause_p: float) -> tuple[float, bool]:
    """The gap (s) after a step: base_s, plus a 0.2–1.0 s pause with probability pause_p, at most
    MAX_GAP_S; and whether it paused."""
    g = base_s
    paused = False
    if rng.random() < pause_p:
        g += rng.uniform(0.2, 1.0)
        paused = True
    return min(g, MAX_GAP_S), paused


def plan_march(p: Planner, a0: int) -> BoutPlan:
    """March in place from about frame a0 (the foot events are added to the planner's feet)."""
    r, body = p.rng, p.body
    a0 += frames(r.uniform(0.0, 0.3))
    cad = r.uniform(0.5, 2.6)
    per = 1.0 / cad
    kl = min(r.uniform(0.03, 0.30), 0.62 * body.thigh_m)
    th = math.acos(1 - kl / body.thigh_m)
    ph = r.uniform(5, 40) * DEG
    asym = r.uniform(0.8, 1.2)
    swfrac = r.uniform(0.5, 0.85)
    pause_p = r.uniform(0.1, 0.4) if r.random() < 0.55 else 0.0
    nsteps = max(2, round(float(r.uniform(3, 11) * cad)))
    nsteps = min(nsteps, 30)
    yaw = p.feet.facing()
    fwd, rgt = facing_vec(yaw), right_vec(yaw)
    drift = r.uniform(0.005, 0.03) if r.random() < 0.3 else 0.0
    ldrift = r.uniform(-0.01, 0.01) if r.random() < 0.2 else 0.0
    slide_p = r.uniform(0.2, 0.6) if r.random() < 0.25 else 0.0
    start = [q.copy() for q in p.feet.pos]
    foot = int(r.integers(2))
    t = a0
    first_a: int | None = None
    last_b = a0
    gaps: list[float] = []
    for k in range(nsteps):
        pj = per * r.uniform(0.85, 1.15)
        sw = float(np.clip(pj * swfrac * r.uniform(0.9, 1.1), 0.2, 1.4))
        base_gap = max(pj - sw, 0.034)
        lift_k = r.uniform(0.85, 1.15) * (asym if foot == 1 else 1.0)
        thk = min(th * lift_k, math.acos(1 - min(0.30, 0.62 * body.thigh_m) / body.thigh_m))
        phk = ph * r.uniform(0.8, 1.2)
        p1 = start[foot] + fwd * drift * (k // 2 + 1) + rgt * ldrift * (k // 2 + 1) + r.normal(0, 0.004, 2)
        a = t
        bb = p.feet.swing(
            foot,
            a,
            frames(sw),
            p1,
            lift=0.0,
            style="march",
            hip_flex_rad=thk,
            shank_rad=phk,
            skew=r.uniform(0.8, 1.25),
        )
        if slide_p and r.random() < slide_p and bb - a > 6:
            ang = r.uniform(0, 2 * math.pi)
            p.feet.slide(
                1 - foot, a + 1, bb - 1, r.uniform(0.01, 0.03) * np.array([math.cos(ang), math.sin(ang)])
            )
        if first_a is None:
            first_a = a
        last_b = bb
        g, _paused = gap_s(r, base_gap, pause_p)
        if k < nsteps - 1:
            t = bb + frames(g)
            gaps.append((t - bb) / FPS)
        foot = 1 - foot
    first_a = a0 if first_a is None else first_a
    kf = r.uniform(5, 15) * DEG
    sway = float(np.clip(r.uniform(0.35, 0.9) - 0.08 * (cad - 1.0), 0.25, 0.95))
    amp = 0.0 if r.random() < 0.35 else r.uniform(10, 40) * DEG
    em = r.uniform(10, 85) * DEG
    i0, n = max(0, first_a - frames(0.4)), last_b - first_a + frames(0.8)

    def chans() -> None:
        w = envelope(n, frames(0.35), frames(0.35))
        p.channels.blend("kflex", i0, kf, w)
        p.channels.blend("sway", i0, sway, w)
        p.channels.blend("armA", i0, amp, w)
        p.channels.blend("eL", i0, em, w)
        p.channels.blend("eR", i0, em, w)
        p.channels.blend("bL", i0, r.uniform(0, 12) * DEG, w)
        p.channels.blend("bR", i0, r.uniform(0, 12) * DEG, w)

    bout = Bout(
        start=first_a,
        end=last_b,
        label="forward",
        tag="march",
        yaw_rad=yaw,
        first_foot=FOOT_NAMES[(foot + nsteps) % 2],
        gaps_s=tuple(gaps),
        cadence_hz=cad,
        knee_lift_m=kl,
        n_steps=nsteps,
    )
    return BoutPlan(bout, chans)


def plan_side(p: Planner, a0: int, label: str, kind: str) -> BoutPlan | None:
    """Side steps of ``kind`` toward ``label`` (left/right) from about frame a0; None if a
    travelling kind cannot make two reps inside the room."""
    r = p.rng
    a0 += frames(r.uniform(0.0, 0.3))
    yaw = p.feet.facing()
    rgt = right_vec(yaw)
    d = -rgt if label == "left" else rgt
    lead = 0 if label == "left" else 1
    trail = 1 - lead
    pause_p = r.uniform(0.25, 0.6) if r.random() < 0.6 else 0.0
    swr: tuple[float, float]
    gapr: tuple[float, float]
    if kind == "shuffle":
        w = r.uniform(0.08, 0.20)
        lift = r.uniform(0.004, 0.012)
        swr = (0.22, 0.45)
        gapr = (0.034, 0.25)
        nrep = int(r.integers(3, 8))
        pause_p *= 0.5
    else:
        w = r.uniform(0.08, 0.45)
        lift = r.uniform(0.015, 0.12)
        swr = (0.3, 0.75)
        gapr = (0.05, 0.45)
        nrep = int(r.integers(2, 7 if kind == "side-step-out-back" else 6))
    if kind != "side-step-out-back":
        # keep inside the room: limit the sideways travel
        c = p.feet.centre()
        nmax = 0
        for k in range(1, nrep + 1):
            e = c + d * w * k
            if np.all(np.abs(e) < ROOM_HALF) and w * k <= 1.3:
                nmax = k
        if nmax < 2:
            return None
        nrep = nmax
    t = a0
    first_a: int | None = None
    last_b = a0
    gaps: list[float] = []
    home = [q.copy() for q in p.feet.pos]
    for k in range(nrep):
        wk = float(np.clip(w * r.uniform(0.85, 1.15), 0.08, 0.45))
        lk = lift * r.uniform(0.75, 1.25)
        if kind == "side-step-out-back":
            seq = [(lead, home[lead] + d * wk), (lead, home[lead] + r.normal(0, 0.006, 2))]
        else:
            pl = p.feet.pos[lead] + d * wk + r.normal(0, 0.005, 2)
            width = float(np.clip(p.body.stance_width_m * r.uniform(0.85, 1.15), 0.08, 0.35))
            pt = pl - d * width + r.normal(0, 0.005, 2)
            seq = [(lead, pl), (trail, pt)]
        for j, (f, p1) in enumerate(seq):
            a = t
            bb = p.feet.swing(
                f, a, frames(r.uniform(*swr)), p1, lift=lk, style="lift", skew=r.uniform(0.8, 1.25)
            )
            if first_a is None:
                first_a = a
            last_b = bb
            last = k == nrep - 1 and j == len(seq) - 1
            if not last:
                g, _ = gap_s(r, r.uniform(*gapr), pause_p)
                t = bb + frames(g)
                gaps.append((t - bb) / FPS)
    first_a = a0 if first_a is None else first_a
    kf = r.uniform(4, 12) * DEG
    sway = r.uniform(0.4, 0.95)
    i0, n = max(0, first_a - frames(0.4)), last_b - first_a + frames(0.8)
    bal = r.uniform(5, 25) * DEG  # balance: the arms abduct a little

    def chans() -> None:
        wv = envelope(n, frames(0.35), frames(0.35))
        p.channels.blend("kflex", i0, kf, wv)
        p.channels.blend("sway", i0, sway, wv)
        p.channels.blend("aL", i0, 80 * DEG, wv * 0.5)
        p.channels.blend("aR", i0, 80 * DEG, wv * 0.5)
        p.channels.blend("bL", i0, bal, wv)
        p.channels.blend("bR", i0, bal, wv)

    bout = Bout(
        start=first_a,
        end=last_b,
        label=label,
        tag=kind,
        yaw_rad=yaw,
        first_foot=FOOT_NAMES[lead],
        gaps_s=tuple(gaps),
        width_m=w,
        n_reps=nrep,
        lift_m=lift,
    )
    return BoutPlan(bout, chans)
