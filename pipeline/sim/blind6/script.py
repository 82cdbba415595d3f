"""Sequence script: alternating still stretches and CPG stepping bouts; labels and tags."""

import numpy as np
from scipy.ndimage import gaussian_filter1d, minimum_filter1d

from pipeline.errors import InputError
from pipeline.sim.blind6.behaviours import STILL, kneel_ok
from pipeline.sim.blind6.body import sample_body, sample_style
from pipeline.sim.blind6.capture import capture
from pipeline.sim.blind6.kinematics import assemble, support_base
from pipeline.sim.blind6.motion import ARMS, FPS, R_BODY, TL, bout, ray_room, rgt

LABELS = ("still", "forward", "left", "right")
STEP_TAGS = ("march", "side-step-out-back", "step-together", "shuffle", "step-touch", "pause")
STILL_TAGS = (
    "turn",
    "weight-shift",
    "sway",
    "dance",
    "gesture",
    "look-around",
    "stretch",
    "bow",
    "crouch",
    "squat",
    "kneel",
    "pick-up",
    "lean",
    "tiptoe",
    "jump",
    "stand-up",
    "idle",
    "",
)
TAGS = STEP_TAGS + STILL_TAGS
AIR_OK = ("turn", "weight-shift", "jump", "kneel", "dance")  # still tags that may lift a foot
PAUSE_MIN = 6  # in-bout double support of >= 0.2 s is tagged 'pause'
R_ALL = 0.73  # every joint stays within this radius (m) of the room centre
B_MIN = 2.0  # seconds reserved for a bout when planning


def _fill_still(tl, n, rng):
    end = tl.k + n
    while tl.k < end:
        rem = end - tl.k
        names, w = [], []
        for name, (_fn, lo, _hi, wt) in STILL.items():
            if lo * FPS <= rem and (name != "kneel" or kneel_ok(tl)):
                names.append(name)
                w.append(wt)
        w = np.array(w) / np.sum(w)
        name = names[int(rng.choice(len(names), p=w))]
        fn, lo, hi, _ = STILL[name]
        nn = round(rng.uniform(lo, min(hi, rem / FPS)) * FPS)
        nn = max(1, min(nn, rem))
        if rem - nn < 15:
            nn = rem
        sl = tl.open(nn)
        fn(tl, sl, nn, rng)
        tl.close()


def _side_pattern(tl, direction, n_hard, rng):
    d = rgt(tl.theta) * (1.0 if direction == "right" else -1.0)
    room = ray_room(tl.c, d, R_BODY)
    pats = ["side-step-out-back", "step-together", "shuffle", "step-touch"]
    w = np.array([0.3, 0.3, 0.2, 0.2 if n_hard > 4 * FPS else 0.0])
    w /= w.sum()
    if room < 0.2:
        return "side-step-out-back"
    return pats[int(rng.choice(4, p=w))]


def _pick_direction(tl, counts, rng):
    w = np.array([1.0 / (1 + counts[d]) for d in ("forward", "left", "right")])
    for j, d in ((1, "left"), (2, "right")):
        dv = rgt(tl.theta) * (1.0 if d == "right" else -1.0)
        if ray_room(tl.c, dv, R_BODY) < 0.2:
            w[j] *= 0.3
    w /= w.sum()
    return ("forward", "left", "right")[int(rng.choice(3, p=w))]


def _idle_layer(tl, rng):
    T, st = tl.T, tl.st
    f = st.fidget

    def sm(sig_s, amp, shape=None):
        x = rng.standard_normal(shape or T)
        x = gaussian_filter1d(x, sig_s * FPS, axis=0, mode="nearest")
        return amp * x / max(x.std(), 1e-9)

    P, A = tl.P, tl.A
    P["px"] += sm(1.5, 0.004 * f)
    P["py"] += sm(1.5, 0.004 * f)
    P["tflex"] += sm(2.0, 0.015 * f)
    P["tlat"] += sm(2.0, 0.01 * f)
    P["hyaw"] += sm(1.0, 0.06 * f)
    P["hpitch"] += sm(1.2, 0.04 * f) + 0.03
    P["hroll"] += sm(1.5, 0.02 * f)
    A["sf"] += sm(1.0, 0.04 * f, (T, 2))
    A["sa"] += st.sa_rest + sm(1.5, 0.02 * f, (T, 2))
    A["el"] += st.el_rest + sm(1.0, 0.05 * f, (T, 2))


def plan_sequence(seed, idx, T):
    rb = np.random.default_rng([seed, idx, 0])
    body, style = sample_body(rb), sample_style(rb)
    rp = np.random.default_rng([seed, idx, 1])  # script decisions
    rm = np.random.default_rng([seed, idx, 2])  # motion details
    r = 0.15 * np.sqrt(rp.uniform())
    a = rp.uniform(-np.pi, np.pi)
    tl = TL(T, body, style, (r * np.cos(a), r * np.sin(a)), rp.uniform(-np.pi, np.pi))
    dirs = list(rp.permutation(["forward", "left", "right"]))
    counts = {"forward": 0, "left": 0, "right": 0}
    S = round(np.clip((T / FPS - 3 * B_MIN) / 4, 0.6, 1.5) * FPS)
    B = int(B_MIN * FPS)
    nb = 0
    while tl.k < T:
        rem = T - tl.k
        pending = max(0, 3 - nb)
        tail = max(pending - 1, 0) * (B + S) + S
        max_still = rem - tail - B
        if max_still < S and (pending == 0 or max_still < 10):
            _fill_still(tl, rem, rm)
            break
        hi = min(int(6 * FPS), max_still)
        n_still = int(rp.integers(min(S, hi), hi + 1))
        _fill_still(tl, n_still, rm)
        n_hard = T - tl.k - tail
        direction = dirs[nb] if nb < 3 else _pick_direction(tl, counts, rp)
        pattern = "march" if direction == "forward" else _side_pattern(tl, direction, n_hard, rp)
        dur = rp.uniform(1.0, min(10.0, max(1.0, n_hard / FPS - 0.5)))
        tl.open(n_hard)
        before = len(tl.bouts)
        n_used = bout(tl, n_hard, direction, pattern, dur, rm)
        tl.end = tl.k + n_used
        tl.tags[tl.k : tl.end] = ""
        tl.close()
        if len(tl.bouts) > before:
            nb += 1
            counts[direction] += 1
    _idle_layer(tl, np.random.default_rng([seed, idx, 5]))
    return body, tl


def labels_and_tags(tl):
    labels = np.full(tl.T, "still", dtype="<U7")
    tags = tl.tags.copy()
    ds = tl.con.all(1)
    for k_lo, k_hi, direction, pattern in tl.bouts:
        labels[k_lo : k_hi + 1] = direction
        tags[k_lo : k_hi + 1] = pattern
        k = k_lo
        while k <= k_hi:
            if ds[k]:
                e = k
                while e + 1 <= k_hi and ds[e + 1]:
                    e += 1
                if e < k_hi and e - k + 1 >= PAUSE_MIN:
                    tags[k : e + 1] = "pause"
                k = e + 1
            else:
                k += 1
    return labels, tags


def _params(tl, gain):
    D = {"feet": tl.feet, "heading": tl.heading, "pabs": tl.pabs, "base": support_base(tl.feet, tl.con)}
    for k, v in tl.P.items():
        D[k] = v * gain if k in ("px", "py", "tflex", "tlat", "ttwist", "pyaw") else v
    rest = {"sf": 0.0, "sa": tl.st.sa_rest, "el": tl.st.el_rest, "tw": 0.0}
    for k in ARMS:
        D[k] = rest[k] + (tl.A[k] - rest[k]) * gain[:, None]
    return D


def generate(seed, idx, T):
    """Clean record (float32 joints) plus internal metadata used by the self-check."""
    body, tl = plan_sequence(seed, idx, T)
    gain = np.ones(T)
    for _ in range(12):  # keep every joint inside the room: damp arm / trunk excursions
        J = assemble(body, _params(tl, gain))
        over = np.linalg.norm(J[:, :, :2], axis=-1).max(1) > R_ALL
        if not over.any():
            break
        g = gain.copy()
        g[over] *= 0.7
        g = minimum_filter1d(g, 15)
        gain = np.minimum(gain, gaussian_filter1d(g, 4.0, mode="nearest"))
        gain[over] = np.minimum(gain[over], g[over])
    labels, tags = labels_and_tags(tl)
    rec = dict(
        joints=J.astype(np.float32),
        fps=np.float64(FPS),
        labels=labels,
        tags=tags.astype("<U20"),
        contacts=tl.con.copy(),
        source=np.array("blind6"),
    )
    meta = dict(body=body, bouts=list(tl.bouts), joints64=J, gain=gain)
    return rec, meta


def make_record(seed, idx, n_frames, captured=True):
    _check_int(seed, "seed", 0, None)
    _check_int(idx, "idx", 0, None)
    _check_int(n_frames, "n_frames", 1, None)
    rec, _ = generate(int(seed), int(idx), int(n_frames))
    if captured:
        rec["joints"] = capture(rec["joints"].astype(np.float64), int(seed), int(idx))
    return rec


def _check_int(v, name, lo, hi):
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
        raise InputError(f"{name} must be an integer, got {v!r}")
    if v < lo or (hi is not None and v > hi):
        raise InputError(f"{name} must be in {lo}..{hi if hi is not None else 'inf'}, got {v}")
