"""Foot-placement / contact / weight timeline (the 'task level' of the model).

The timeline records, per frame, where each ankle is, whether the foot is in
contact, the share of body weight on the left foot (which defines the centre
of pressure reference for the LIPM/DCM layer) and a handful of posture
targets (pelvis height offset, trunk pitch/roll, head yaw, gesture envelopes).
Nothing here produces joints; body.py turns it into a skeleton.
"""

import numpy as np

FPS = 30.0


def mj(s):
    """Minimum-jerk 0->1 profile."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10.0 - 15.0 * s + 6.0 * s * s)


def bump(s):
    """Smooth 0->1->0 profile with zero end slopes, peak 1 at s=0.5."""
    s = np.clip(s, 0.0, 1.0)
    return 16.0 * s * s * (1.0 - s) ** 2


def envelope(n, ramp):
    """Plateau envelope of n frames with min-jerk ramps of `ramp` frames."""
    k = np.arange(n) + 0.5
    r = max(1.0, min(float(ramp), n / 2.0))
    return np.minimum(mj(k / r), mj((n - k) / r))


def fwd_of(theta):
    return np.array([-np.sin(theta), np.cos(theta)])


def right_of(theta):
    return np.array([np.cos(theta), np.sin(theta)])


class Timeline:
    CHANNELS = (
        "zmod",
        "pel_back",
        "pitch",
        "roll",
        "hyaw",
        "hpitch",
        "tyaw",
        "pointL",
        "pointR",
        "waveL",
        "waveR",
        "stretch",
        "armfwd",
        "pt_elev",
        "pt_az",
        "wave_f",
    )

    def __init__(self, P, n_frames, centre, theta):
        self.P = P
        self.T = n_frames
        N = n_frames + int(40 * FPS)
        self.N = N
        self.ank = np.zeros((N, 2, 3))
        self.fyaw = np.zeros((N, 2))
        self.con = np.ones((N, 2), bool)
        self.w = np.full(N, 0.5)
        self.ch = {k: np.zeros(N) for k in self.CHANNELS}
        self.label = np.zeros(N, np.int8)  # 0 still 1 forward 2 left 3 right
        self.tag = np.full(N, "", dtype="<U20")
        self.bout_id = np.full(N, -1, np.int32)
        self.t = 0
        self.c = np.asarray(centre, float)
        self.theta = float(theta)
        self.feet = [self.home(0), self.home(1)]
        self.fz = [P["ha"], P["ha"]]
        self.yaw = [self.theta, self.theta]
        self.curw = 0.5
        self.bouts = []  # (label, pattern, start, end)

    # -- geometry -------------------------------------------------------
    def home(self, i, c=None, theta=None):
        c = self.c if c is None else c
        theta = self.theta if theta is None else theta
        s = -1.0 if i == 0 else 1.0
        return c + s * 0.5 * self.P["stance"] * right_of(theta)

    @property
    def room(self):
        return self.t >= self.N - int(12 * FPS)

    # -- primitive operations ------------------------------------------
    def _plant(self, a, b, i):
        self.ank[a:b, i, :2] = self.feet[i]
        self.ank[a:b, i, 2] = self.fz[i]
        self.fyaw[a:b, i] = self.yaw[i]
        self.con[a:b, i] = True

    def hold(self, n, w_to=None, ramp=None, tag=None):
        """Both feet planted for n frames; weight ramps to w_to."""
        n = int(max(0, min(n, self.N - self.t)))
        if n == 0:
            return
        a, b = self.t, self.t + n
        self._plant(a, b, 0)
        self._plant(a, b, 1)
        if w_to is None:
            self.w[a:b] = self.curw
        else:
            r = n if ramp is None else max(1, min(int(ramp), n))
            prof = mj((np.arange(n) + 1.0) / r)
            self.w[a:b] = self.curw + (w_to - self.curw) * prof
            self.curw = float(self.w[b - 1])
        if tag is not None:
            self.tag[a:b] = tag
        self.t = b

    def weights(self, wseq):
        """Both feet planted, explicit weight trajectory."""
        n = int(min(len(wseq), self.N - self.t))
        a, b = self.t, self.t + n
        self._plant(a, b, 0)
        self._plant(a, b, 1)
        self.w[a:b] = wseq[:n]
        self.curw = float(self.w[b - 1])
        self.t = b

    def swing(self, i, target, n, apex, fwd_off=0.0, z_to=None, yaw_to=None):
        """Foot i in the air for n frames, lands on `target` at frame t+n."""
        n = int(max(1, min(n, self.N - self.t)))
        a, b = self.t, self.t + n
        o = 1 - i
        self._plant(a, b, o)
        self.con[a:b, i] = False
        s = (np.arange(n) + 1.0) / (n + 1.0)
        p0, p1 = self.feet[i], np.asarray(target, float)
        z0 = self.fz[i]
        z1 = z0 if z_to is None else z_to
        y0 = self.yaw[i]
        y1 = y0 if yaw_to is None else yaw_to
        yw = y0 + (y1 - y0) * mj(s)
        f = np.stack([-np.sin(yw), np.cos(yw)], 1)
        self.ank[a:b, i, :2] = p0 + (p1 - p0) * mj(s)[:, None] + (fwd_off * bump(s))[:, None] * f
        self.ank[a:b, i, 2] = z0 + (z1 - z0) * mj(s) + apex * bump(s)
        self.fyaw[a:b, i] = yw
        self.w[a:b] = 1.0 if i == 1 else 0.0
        self.curw = 1.0 if i == 1 else 0.0
        self.feet[i] = p1.copy()
        self.fz[i] = z1
        self.yaw[i] = y1
        self.t = b

    def flight(self, n, h):
        """Both feet off the floor (jump), ballistic foot height profile."""
        n = int(max(1, min(n, self.N - self.t)))
        a, b = self.t, self.t + n
        s = (np.arange(n) + 1.0) / (n + 1.0)
        for i in (0, 1):
            self._plant(a, b, i)
            self.con[a:b, i] = False
            self.ank[a:b, i, 2] += h * 4.0 * s * (1.0 - s)
        self.ch["zmod"][a:b] += h * 4.0 * s * (1.0 - s)
        self.w[a:b] = self.curw
        self.t = b

    def add(self, name, a, values):
        values = np.asarray(values, float)
        b = min(a + len(values), self.N)
        self.ch[name][a:b] += values[: b - a]

    def setv(self, name, a, values):
        values = np.asarray(values, float)
        b = min(a + len(values), self.N)
        self.ch[name][a:b] = values[: b - a]
