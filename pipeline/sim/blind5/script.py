"""Sequence script: alternate still stretches and stepping bouts; idle layer; generation."""

import numpy as np

from pipeline.sim.blind5.body import sample_body
from pipeline.sim.blind5.curves import drift
from pipeline.sim.blind5.skeleton import compose
from pipeline.sim.blind5.stepping import run_bout
from pipeline.sim.blind5.still import fill_still
from pipeline.sim.blind5.timeline import Timeline

FPS = 30.0
S_BODY, S_SCRIPT, S_IDLE = 1, 2, 3


def stream(seed, idx, sid):
    return np.random.default_rng([int(seed), int(idx), int(sid)])


def sample_style(rng, body):
    return {
        "cadence": rng.uniform(0.8, 2.2),
        "lift": rng.uniform(0.05, 0.2),
        "arm": rng.uniform(5.0, 35.0),
        "asym_lift": rng.uniform(-0.15, 0.15),
        "asym_time": rng.uniform(-0.08, 0.08),
        "width": 2 * body.hip_hw * rng.uniform(0.95, 1.45),
        "sway": rng.uniform(0.02, 0.06),
        "jitter": rng.uniform(0.04, 0.14),
        "speed": rng.uniform(0.8, 1.5),
        "idle": rng.uniform(0.6, 1.4),
    }


def _schedule(tl, rng):
    n, fr = tl.T, tl.fr
    order = [str(x) for x in rng.permutation(["forward", "left", "right"])]
    bmin, gmin = fr(2.0), fr(1.5)
    cur, nb = 0, 0
    while True:
        k = max(0, 3 - nb)  # mandatory bouts still to place
        lo = fr(1.0) if cur == 0 else gmin
        ds = fr(rng.uniform(1.0, 4.0) if cur == 0 else 1.5 + 4.5 * rng.beta(1.6, 1.0))
        ds = max(lo, min(ds, n - cur - k * bmin - max(k - 1, 0) * gmin))
        if k == 0 and cur + ds + bmin + 1 > n:
            break
        fill_still(tl, cur, cur + ds, rng)
        cur += ds
        label = order[nb] if nb < 3 else ["forward", "left", "right"][int(rng.integers(3))]
        db = fr(2.3 + 8.0 * rng.beta(1.2, 2.2))
        k2 = max(0, 3 - nb - 1)
        db = max(min(db, n - cur - k2 * (bmin + gmin)), fr(1.0))
        last = run_bout(tl, cur, min(cur + db, n - 1), label, rng)
        cur, nb = last + 1, nb + 1
    if cur < n:
        fill_still(tl, cur, n, rng)


def _idle_layer(tl, rng):
    """Additive breathing + slow random drift on the upper body and pelvis."""
    n, fps, a = tl.T, tl.fps, tl.style["idle"]
    amps = {
        "sp_pitch": 2.0,
        "sp_roll": 1.5,
        "sp_yaw": 3.0,
        "hd_pitch": 5.0,
        "hd_roll": 2.0,
        "hd_yaw": 6.0,
        "la_flex": 4.0,
        "ra_flex": 4.0,
        "la_abd": 3.0,
        "ra_abd": 3.0,
        "la_elb": 5.0,
        "ra_elb": 5.0,
        "la_twist": 6.0,
        "ra_twist": 6.0,
        "pel_yaw": 2.0,
        "pel_x": 0.008,
        "pel_y": 0.008,
    }
    for name, amp in amps.items():
        tl.ch[name] += drift(rng, n, fps, amp * a)
    t = np.arange(n) / fps
    f = rng.uniform(0.2, 0.33)
    tl.ch["sp_pitch"] += 0.7 * np.sin(2 * np.pi * f * t + rng.uniform(0, 6.3))


def generate(seed, idx, n_frames):
    """Noise-free sequence: dict(joints (T,17,3) float64, contacts, labels, tags, ankle_h, body)."""
    rb, rs, ri = stream(seed, idx, S_BODY), stream(seed, idx, S_SCRIPT), stream(seed, idx, S_IDLE)
    body = sample_body(rb)
    style = sample_style(rb, body)
    heading = rs.uniform(-np.pi, np.pi)
    ang, rad = rs.uniform(-np.pi, np.pi), 0.2 * np.sqrt(rs.uniform()) * 0.9
    tl = Timeline(int(n_frames), FPS, body, style, heading, rad * np.array([np.cos(ang), np.sin(ang)]))
    _schedule(tl, rs)
    _idle_layer(tl, ri)
    joints, _ank = compose(tl)
    return {
        "joints": joints,
        "contacts": tl.contact.copy(),
        "labels": tl.labels.copy(),
        "tags": tl.tags.copy(),
        "ankle_h": body.ankle_h,
        "body": body,
    }
