"""Timeline of per-frame motion parameters and the CPG-driven stepping bouts."""

import numpy as np

from pipeline.sim.blind6.oscillators import OU, HopfCPG

FPS = 30.0
SUB = 8  # integration sub-steps per frame (dt = 1/240 s)
MINLIFT = 0.003  # a swinging ankle is always at least 3 mm up
SCAL = (
    "px",
    "py",
    "pz",
    "lift",
    "pyaw",
    "proll",
    "ptilt",
    "tflex",
    "tlat",
    "ttwist",
    "hyaw",
    "hpitch",
    "hroll",
    "pabs_w",
)
ARMS = ("sf", "sa", "el", "tw")
TRAVEL = ("step-together", "shuffle", "step-touch")
R_BODY = 0.25  # the support centre stays within this radius of the room centre
R_FOOT = 0.66  # and every ankle within this one


def s01(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * x * (10 + x * (-15 + 6 * x))


def bump(s, g=1.0):
    s = np.clip(s, 0.0, 1.0)
    return np.sin(np.pi * s**g) ** 0.8


def env(n, up, dn):
    """0 at both ends, 1 in the middle, smooth ramps of up / dn frames."""
    e = np.ones(n)
    up = int(max(1, min(up, n // 2)))
    dn = int(max(1, min(dn, n // 2)))
    e[:up] = s01(np.arange(up) / up)
    e[n - dn :] = np.minimum(e[n - dn :], s01(np.arange(dn)[::-1] / dn))
    return e


def keys(n, vals):
    """Min-jerk interpolation through key values spread evenly over n frames."""
    vals = np.asarray(vals, float)
    m = len(vals) - 1
    x = np.arange(n) / max(n - 1, 1) * m
    i = np.minimum(x.astype(int), m - 1)
    return vals[i] + (vals[i + 1] - vals[i]) * s01(x - i)


def fwd(th):
    return np.array([-np.sin(th), np.cos(th)])


def rgt(th):
    return np.array([np.cos(th), np.sin(th)])


def ray_room(p, v, R):
    """Largest w >= 0 with |p + w v| <= R (v a unit vector)."""
    b = float(p @ v)
    disc = b * b - (float(p @ p) - R * R)
    return 0.0 if disc < 0 else max(0.0, -b + np.sqrt(disc))


def jit2(rng, s, cap):
    v = rng.normal(0.0, s, 2)
    n = np.hypot(*v)
    return v if n <= cap else v * cap / n


class TL:
    """Per-frame parameter arrays filled segment by segment."""

    def __init__(self, T, body, style, c, theta):
        self.T, self.b, self.st = T, body, style
        self.feet = np.zeros((T, 2, 3))
        self.con = np.ones((T, 2), bool)
        self.heading = np.zeros(T)
        self.P = {k: np.zeros(T) for k in SCAL}
        self.A = {k: np.zeros((T, 2)) for k in ARMS}
        self.pabs = np.zeros((T, 2))
        self.tags = np.full(T, "", dtype="<U20")
        self.bouts = []
        self.c = np.asarray(c, float)
        self.theta = float(theta)
        self.cur = np.stack([self.home(0), self.home(1)])
        self.k = 0
        self.end = 0

    def home(self, i, c=None, th=None):
        c = self.c if c is None else c
        th = self.theta if th is None else th
        xy = c + (-0.5 if i == 0 else 0.5) * self.b.stance * rgt(th)
        return np.array([xy[0], xy[1], self.b.ankle_h])

    def open(self, n):
        sl = slice(self.k, self.k + n)
        self.feet[sl] = self.cur
        self.heading[sl] = self.theta
        self.end = self.k + n
        return sl

    def close(self):
        self.k = self.end
        self.c = self.cur[:, :2].mean(0)

    def put(self, i, k, pos):
        self.feet[k : self.end, i] = pos
        self.cur[i] = pos

    def swing(self, i, k, n, p1, lift, g=1.0):
        """A swing of foot i over frames k..k+n-1, landing (contact) at frame k+n."""
        p0 = self.cur[i].copy()
        p1 = np.asarray(p1, float)
        s = np.arange(1, n + 1) / (n + 1)
        e = s01(s)
        self.feet[k : k + n, i] = p0 + (p1 - p0) * e[:, None]
        self.feet[k : k + n, i, 2] += np.maximum(lift * bump(s, g), MINLIFT)
        self.con[k : k + n, i] = False
        self.put(i, k + n, p1)


# ----------------------------------------------------------------------------- stepping


def _seg(p0, p1, lift, g, fo, s, ah):
    pos = p0 + (p1 - p0) * s01(s)
    bm = bump(s, g)
    pos[:2] += fo * bm
    pos[2] = ah + max(lift * bm, MINLIFT)
    return pos


def traj(sp, s, ah):
    """Swing foot position at swing progress s in [0, 1); returns (pos, contact)."""
    if sp["tap"] is None:
        return _seg(sp["p0"], sp["p1"], sp["lift"], sp["g"], sp["fo"], s, ah), False
    if s < 0.45:
        return _seg(sp["p0"], sp["tap"], 0.7 * sp["lift"], 1.0, 0 * sp["fo"], s / 0.45, ah), False
    if s < 0.6:
        return sp["tap"].copy(), True
    return _seg(sp["tap"], sp["p1"], 0.5 * sp["lift"], 1.0, 0 * sp["fo"], (s - 0.6) / 0.4, ah), False


class _Plan:
    """Decides, each time a leg oscillator enters its swing window, what that swing does."""

    def __init__(self, tl, pattern, lead, dvec, lifts, width, skip, est, n_hard, rng, F, kf, g):
        self.tl, self.pattern, self.lead, self.dvec = tl, pattern, lead, dvec
        self.lifts, self.width, self.est, self.n_hard, self.rng = lifts, width, est, n_hard, rng
        self.F, self.kf, self.g = F, kf, g
        self.travel = pattern in TRAVEL
        if pattern == "march":
            self.seq, self.decide = ["m"], "m"
        elif pattern == "side-step-out-back":
            self.seq = ["out", "back"] if skip else ["out", "mid", "back", "mid2"]
            self.decide = "out" if skip else "mid2"
        else:
            self.seq, self.decide = ["out", "follow"], "out"
        self.need = {"m": 1, "out": min(3, len(self.seq)), "mid2": 3}
        self.pos, self.started, self.done = 0, False, False
        self.c = tl.c.copy()
        to_c = -self.c / max(np.linalg.norm(self.c), 1e-6)
        d = to_c * min(1.0, 4 * np.linalg.norm(self.c)) + rng.normal(0, 0.4, 2)
        self.drift = d / max(np.linalg.norm(d), 1e-6) * rng.uniform(0.002, 0.012)
        self.w_next = 0.0
        self.new_lead = None

    def leg_of(self, role):
        if role == "m":
            return None
        return self.lead if role in ("out", "back") else 1 - self.lead

    def _width(self, rn):
        w0 = float(
            np.clip(self.width * (0.6 + 0.4 * min(rn, 1.0)) * self.rng.uniform(0.85, 1.15), 0.08, 0.43)
        )
        room_c = ray_room(self.c, self.dvec, R_BODY)
        room_f = ray_room(self.tl.cur[self.lead, :2], self.dvec, R_FOOT)
        return min(w0, room_c, room_f)

    def window(self, i, rn, k):
        if self.done:
            return None
        role = self.seq[self.pos]
        leg = self.leg_of(role)
        if leg is not None and leg != i:
            return None
        if (not self.started) or role == self.decide:
            need = self.need[role]
            late = k + need * self.est + 12 > self.n_hard
            ok = rn >= (0.2 if not self.started else 0.3) and not late
            if ok and role == "out" and self.travel:
                self.w_next = self._width(rn)
                ok = self.w_next >= 0.08
            if not ok:
                if self.started or late:
                    self.done = True
                return None
            self.started = True
        sp = self._make(role, i, rn)
        self.pos = (self.pos + 1) % len(self.seq)
        return sp

    def _make(self, role, i, rn):
        tl, rng, ah = self.tl, self.rng, self.tl.b.ankle_h
        cur = tl.cur[i].copy()
        lift = max(self.lifts[i] * min(1.0, rn / 0.95) * rng.uniform(0.85, 1.15), 0.004)
        tap = None
        fo = np.zeros(2)
        if role == "m":
            c = self.c + self.drift * rng.uniform(0.0, 1.0)
            if np.linalg.norm(c) < R_BODY:
                self.c = c
            tgt = tl.home(i, self.c)
            tgt[:2] += jit2(rng, 0.012, 0.03)
            fo = self.F * lift * self.kf
        elif role == "out":
            if self.travel:
                w, base = self.w_next, cur
            else:
                base = tl.home(i, self.c)
                w = self.width * (0.6 + 0.4 * min(rn, 1.0)) * rng.uniform(0.85, 1.15)
                w = max(0.08, min(w, 0.43, ray_room(base[:2], self.dvec, R_FOOT)))
            tgt = base.copy()
            tgt[:2] += self.dvec * w + self.F * rng.normal(0, 0.008)
            self.new_lead = tgt.copy()
        elif role == "follow":
            gap = tl.b.stance * (
                rng.uniform(0.85, 1.0) if self.pattern == "shuffle" else rng.uniform(0.95, 1.05)
            )
            tgt = self.new_lead.copy()
            tgt[:2] += -self.dvec * gap + self.F * rng.normal(0, 0.008)
            if self.pattern == "step-touch":
                tap = self.new_lead.copy()
                tap[:2] += -self.dvec * max(0.10, 0.6 * tl.b.stance) * rng.uniform(
                    0.9, 1.1
                ) - self.F * rng.uniform(0.0, 0.05)
                tap[2] = ah
            self.c = 0.5 * (tgt[:2] + self.new_lead[:2])
        else:  # 'back' to the home spot, or a small in-place step of the trailing foot
            tgt = tl.home(i, self.c)
            tgt[:2] += jit2(rng, 0.006, 0.012)
            if role != "back":
                lift = rng.uniform(0.01, 0.03) * min(1.0, rn)
        tgt[2] = ah
        return dict(p0=cur, p1=tgt, lift=lift, g=self.g, fo=fo, tap=tap)


def bout(tl, n_hard, direction, pattern, dur, rng):
    """One stepping bout from the current state; fills at most n_hard frames from tl.k.

    Returns the number of frames used; appends (k_lo, k_hi, direction, pattern) to
    tl.bouts when at least one step was made (k_lo = first lift-off frame, k_hi = last
    touch-down frame)."""
    b, st = tl.b, tl.st
    k0 = tl.k
    th = tl.theta
    F, R = fwd(th), rgt(th)
    cad = float(np.clip(st.cadence * rng.uniform(0.75, 1.3), 0.5, 2.6))
    short = n_hard < 3.5 * FPS  # tight budget (short files): quick steps
    cad = min(2.6, max(cad, 1.3 * 2.5 / max(n_hard / FPS - 0.7, 0.3)))
    if pattern == "step-touch":
        cad = min(cad, 1.6)
    if pattern == "shuffle":
        cad = max(cad, 1.0)
    lo = max(0.3, 0.5 - 0.3 * cad)  # keeps ordinary double support <= 0.8 s
    if pattern == "step-touch":
        lo = max(lo, 0.42)
    sf0 = float(np.clip(st.sf + rng.normal(0, 0.03), lo, 0.47))
    if short and pattern == "side-step-out-back":  # fast enough to let the trailing foot rest
        cad = min(2.6, max(cad, (1 - sf0) * 2 / (0.75 * 0.85) + 0.02))
    om0 = np.pi * cad  # one leg cycle = two steps
    da = rng.uniform(-0.03, 0.03)
    sfs = np.clip([sf0 + da, sf0 - da], lo, 0.47)
    side = direction != "forward"
    dvec = R * (1.0 if direction == "right" else -1.0)
    lead = (1 if direction == "right" else 0) if side else int(rng.integers(2))
    if pattern == "march":
        lm = float(np.clip(st.lift * rng.uniform(0.75, 1.3), 0.03, 0.30))
    elif pattern == "shuffle":
        lm = rng.uniform(0.006, 0.022)
    else:
        lm = float(np.clip(st.side_lift * rng.uniform(0.7, 1.3), 0.015, 0.12))
    lifts = lm * np.array([np.sqrt(st.asym), 1 / np.sqrt(st.asym)])
    if pattern == "march":
        lifts = np.clip(lifts, 0.03, 0.30)
    if pattern == "shuffle":
        lifts = np.minimum(lifts, 0.026)
    if pattern == "shuffle":
        width = rng.uniform(0.08, 0.2)
    elif pattern in TRAVEL:  # travelling steps: narrower, so that a few fit in the room
        width = float(np.clip(st.side_w * rng.uniform(0.5, 1.0), 0.08, 0.3))
    else:
        width = float(np.clip(st.side_w * rng.uniform(0.7, 1.3), 0.08, 0.43))
    arm = st.arm * rng.uniform(0.7, 1.3) if rng.random() < 0.8 else 0.0
    if side:
        arm *= 0.35
    sway = st.sway * rng.uniform(0.6, 1.4) * (0.5 if side else 1.0)
    ramp_up = min(rng.uniform(0.3, 0.8), 0.2 * n_hard / FPS)
    ramp_dn = rng.uniform(0.4, 1.0)
    t_stop = max(ramp_up + 2.0 / cad, dur - ramp_dn)
    pausing = st.pause_p > 0 and rng.random() < 0.5
    est = FPS / cad * 1.3
    skip = False
    if pattern == "side-step-out-back":
        skip = (1 - sf0) * 2 * np.pi / (0.75 * om0) <= 0.85 and (short or rng.random() < 0.6)
    kf = st.kfwd * rng.uniform(0.7, 1.3)
    plan = _Plan(tl, pattern, lead, dvec, lifts, width, skip, est, n_hard, rng, F, kf, st.gamma)

    cpg = HopfCPG()
    jit = OU(st.jitter, 0.6, rng)
    t_first = ramp_up * rng.uniform(0.75, 0.95)
    Phi = np.zeros(2)
    Phi[lead] = -om0 * t_first
    Phi[1 - lead] = Phi[lead] - np.pi
    z = 0.3 * np.exp(1j * np.array([Phi[0], Phi[1], Phi[1], Phi[0]]))
    last_cyc = np.floor(Phi / (2 * np.pi))
    swing = [None, None]
    holds = []
    osc = np.zeros((n_hard, 4), complex)
    dt = 1.0 / (FPS * SUB)
    k_done, n_end, n_used = None, None, None
    settle = int(rng.integers(9, 19))
    ah = b.ankle_h
    for k in range(n_hard):
        t = k / FPS
        osc[k] = z
        rn = np.abs(z[:2])
        for i in (0, 1):  # touch-downs first
            sp = swing[i]
            if sp is None:
                continue
            s = (Phi[i] - sp["phi0"]) / (2 * np.pi * sfs[i])
            if s >= 1.0:
                swing[i] = None
                tl.cur[i] = sp["p1"]
                h = _pause(plan, pausing, st.pause_p, sfs[i], om0, k, est, n_hard, rng)
                if h > 0:
                    holds.append((t, t + h))
            else:
                pos, c = traj(sp, s, ah)
                tl.feet[k0 + k, i] = pos
                tl.con[k0 + k, i] = c
        for i in (0, 1):  # then lift-offs
            cyc = np.floor(Phi[i] / (2 * np.pi))
            psi = Phi[i] - 2 * np.pi * cyc
            if swing[i] is None and cyc > last_cyc[i] and psi < 2 * np.pi * sfs[i]:
                last_cyc[i] = cyc
                sp = plan.window(i, rn[i], k) if swing[1 - i] is None else None
                if sp is not None:
                    sp["phi0"] = 2 * np.pi * cyc
                    swing[i] = sp
                    pos, c = traj(sp, psi / (2 * np.pi * sfs[i]), ah)
                    tl.feet[k0 + k, i] = pos
                    tl.con[k0 + k, i] = c
        for i in (0, 1):
            if swing[i] is None:
                tl.feet[k0 + k, i] = tl.cur[i]
                tl.con[k0 + k, i] = True
        if k_done is None and plan.done and swing[0] is None and swing[1] is None:
            k_done, n_end = k, k + settle
            t_stop = min(t_stop, t)
        if n_end is not None and k >= min(n_end, n_hard - 1):
            n_used = k + 1
            break
        for sub in range(SUB):  # integrate the CPG to the next frame
            ts = t + sub * dt
            if ts < ramp_up:
                mu = 0.1 + 0.9 * s01(ts / ramp_up)
            elif ts > t_stop:
                mu = 1.0 - s01((ts - t_stop) / ramp_dn)
            else:
                mu = 1.0
            hf = 1.0
            for h0, h1 in holds:
                if h0 <= ts <= h1:
                    hf = 1.0 - 0.97 * min(1.0, (ts - h0) / 0.1, (h1 - ts) / 0.1)
            om = om0 * (1.0 + jit.step(dt)) * hf
            zn = cpg.rk4(z, mu, om, dt)
            Phi += np.angle(zn[:2] / z[:2])
            z = zn
    if n_used is None:
        if swing[0] is not None or swing[1] is not None:
            raise RuntimeError("bout ran out of frames mid-swing")
        n_used = n_hard
        k_done = k_done if k_done is not None else n_used - 1
    sl = slice(k0, k0 + n_used)
    tl.feet[k0 + n_used : tl.end] = tl.cur
    # posture driven by the oscillators, faded in / out at the bout edges
    Z = osc[:n_used]
    fade = np.ones(n_used)
    fade[:6] = s01(np.arange(6) / 6)
    nf = n_used - k_done
    fade[k_done:] = s01(np.arange(nf)[::-1] / max(nf - 1, 1))
    fade[-1] = 0.0
    beta = np.pi / 2 - np.pi * sfs
    uL = (Z[:, 0] * np.exp(1j * beta[0])).imag
    uR = (Z[:, 1] * np.exp(1j * beta[1])).imag
    P, A = tl.P, tl.A
    P["px"][sl] += fade * 0.5 * sway * (uL - uR)
    P["proll"][sl] += fade * 0.5 * st.roll * (uR - uL)
    P["tlat"][sl] += fade * 0.3 * st.roll * (uL - uR)
    yaw = fade * 0.03 * (uR - uL) * (1 if arm > 0 else 0.5)
    P["pyaw"][sl] += yaw
    P["ttwist"][sl] -= 1.5 * yaw
    P["pz"][sl] += fade * st.bob * 0.5 * (np.abs(Z[:, 0]) ** 2 + (Z[:, 0] ** 2 * np.exp(2j * beta[0])).real)
    P["tflex"][sl] += fade * np.abs(Z[:, 0]) * rng.uniform(-0.02, 0.08)
    if rng.random() < 0.3:
        P["hpitch"][sl] += fade * rng.uniform(0.1, 0.4)
    for a, leg in ((0, 1), (1, 0)):  # each arm swings with the contralateral leg
        ca = Z[:, 2 + a] * np.exp(-1j * np.pi * sfs[leg])
        A["sf"][sl, a] += fade * arm * ca.real
        A["el"][sl, a] += fade * 0.4 * arm * 0.5 * (np.abs(ca) + ca.real)
        if side:
            A["sa"][sl, a] += fade * 0.1 * np.abs(Z[:, 2 + a])
    if plan.started:
        swinging = ~tl.con[sl].all(1)
        idx = np.nonzero(swinging)[0]
        k_lo, k_hi = k0 + idx[0], k0 + idx[-1] + 1
        tl.bouts.append((int(k_lo), int(k_hi), direction, pattern))
    return n_used


def _pause(plan, pausing, p, sf, om0, k, est, n_hard, rng):
    """Hold the rhythm (phase frozen) after a touch-down: a pause of the whole step cycle."""
    if not (pausing and plan.started and not plan.done) or plan.seq == ["out", "back"]:
        return 0.0
    if rng.random() >= p:
        return 0.0
    ds = (np.pi - 2 * np.pi * sf) / om0  # ordinary double support until the next lift-off
    h = rng.uniform(0.25, 1.0) - ds
    if h < 0.1 or ds * 1.34 + h > 0.92 or k + h * FPS + 2 * est + 14 > n_hard:
        return 0.0
    return h
