"""Per-sequence animation state: keyed channels, foot swings, contacts, labels."""

import numpy as np

from pipeline.sim.blind5.curves import ease_keys, spline

CHANNELS = [
    "pel_x",
    "pel_y",
    "pel_z",
    "pel_pitch",
    "pel_roll",
    "pel_yaw",
    "sp_pitch",
    "sp_roll",
    "sp_yaw",
    "hd_pitch",
    "hd_roll",
    "hd_yaw",
    "la_flex",
    "la_abd",
    "la_twist",
    "la_elb",
    "ra_flex",
    "ra_abd",
    "ra_twist",
    "ra_elb",
    "heel_l",
    "heel_r",
]
# rest pose (degrees); behaviour targets are absolute, stored as offsets from this
NEUTRAL = {
    "sp_pitch": 2.0,
    "la_flex": 3.0,
    "ra_flex": 3.0,
    "la_abd": 7.0,
    "ra_abd": 7.0,
    "la_elb": 12.0,
    "ra_elb": 12.0,
    "la_twist": 10.0,
    "ra_twist": 10.0,
}


def right_vec(th):
    return np.array([np.cos(th), np.sin(th)])


def fwd_vec(th):
    return np.array([-np.sin(th), np.cos(th)])


class Timeline:
    def __init__(self, n, fps, body, style, heading, centre):
        self.T, self.fps, self.body, self.style = n, fps, body, style
        self.ch = {c: np.zeros(n) for c in CHANNELS}
        for k, v in NEUTRAL.items():
            self.ch[k] += v
        self.contact = np.ones((n, 2), dtype=bool)
        self.labels = np.full(n, "still", dtype="<U7")
        self.tags = np.full(n, "", dtype="<U20")
        self.heading = float(heading)
        w = style["width"] / 2.0
        r = right_vec(heading)
        self.feet = np.array([centre - r * w, centre + r * w])
        self.fyaw = np.array([heading, heading], dtype=float)
        self.feet0, self.fyaw0 = self.feet.copy(), self.fyaw.copy()
        self.swings = [[], []]
        self.head_keys = [(0.0, self.heading)]
        self.shift_keys = []

    # ---- helpers -------------------------------------------------------
    def fr(self, seconds):
        return round(seconds * self.fps)

    def add_keys(self, name, a, keys, tension=1.0, absolute=True):
        """Additive keyed layer on channel `name` starting at frame a.
        keys: (seconds from a, value). Absolute values are taken relative to NEUTRAL
        at the first and last key so that the layer blends in and out."""
        kt = a + np.array([k[0] for k in keys], dtype=float) * self.fps
        kv = np.array([k[1] for k in keys], dtype=float)
        if absolute and name in NEUTRAL:
            kv = np.where(np.arange(len(kv)) % (len(kv) - 1) == 0, 0.0, kv - NEUTRAL[name])
        self.add_frame_keys(name, kt, kv, tension)

    def add_frame_keys(self, name, kt, kv, tension=1.0):
        kt = np.asarray(kt, dtype=float)
        order = np.argsort(kt, kind="stable")
        kt, kv = kt[order], np.asarray(kv, dtype=float)[order]
        f0, f1 = max(int(np.ceil(kt[0])), 0), min(int(np.floor(kt[-1])), self.T - 1)
        if f1 < f0:
            return
        t = np.arange(f0, f1 + 1, dtype=float)
        self.ch[name][f0 : f1 + 1] += spline(t, kt, kv, tension)

    def swing(
        self,
        foot,
        L,
        D,
        B,
        yaw_b=None,
        hkeys=((0.0, 0.0), (1.0, 1.0)),
        zkeys=((0.0, 0.0), (0.5, 0.05), (1.0, 0.0)),
    ):
        """Foot `foot` lifts at frame L (first airborne frame), lands at D (first contact frame)."""
        assert 1 <= L < D < self.T
        yaw_b = self.fyaw[foot] if yaw_b is None else yaw_b
        self.swings[foot].append(
            (L, D, self.feet[foot].copy(), np.asarray(B, float), self.fyaw[foot], yaw_b, hkeys, zkeys)
        )
        self.contact[L:D, foot] = False
        self.feet[foot] = B
        self.fyaw[foot] = yaw_b

    def turn_heading(self, f0, f1, new):
        self.head_keys += [(float(f0), self.heading), (float(f1), float(new))]
        self.heading = float(new)

    # ---- evaluated tracks ---------------------------------------------
    def ankle_tracks(self):
        n = self.T
        xy = np.zeros((n, 2, 2))
        yaw = np.zeros((n, 2))
        lift = np.zeros((n, 2))
        for k in range(2):
            xy[:, k] = self.feet0[k]
            yaw[:, k] = self.fyaw0[k]
            for L, D, A, B, ya, yb, hk, zk in self.swings[k]:
                xy[D:, k] = B
                yaw[D:, k] = yb
                s = (np.arange(L, D) - (L - 1)) / (D - (L - 1))
                g = ease_keys(s, [h[0] for h in hk], [h[1] for h in hk])
                xy[L:D, k] = A + (B - A) * g[:, None]
                yaw[L:D, k] = ya + (yb - ya) * g
                lift[L:D, k] = ease_keys(s, [z[0] for z in zk], [z[1] for z in zk])
        heel = np.stack([self.ch["heel_l"], self.ch["heel_r"]], 1)
        z = self.body.ankle_h + lift + np.where(self.contact, np.maximum(heel, 0.0), 0.0)
        return np.concatenate([xy, z[:, :, None]], 2), yaw

    def heading_track(self):
        keys = sorted([*self.head_keys, (float(self.T - 1), self.heading)])
        kt, kv = [], []
        for t, v in keys:
            if kt and t <= kt[-1]:
                kv[-1] = v
            else:
                kt.append(t)
                kv.append(v)
        return ease_keys(np.arange(self.T, dtype=float), kt, kv)

    def shift_track(self):
        keys = {0.0: np.zeros(2), float(self.T - 1): np.zeros(2)}
        for t, v in self.shift_keys:
            keys[float(np.clip(round(t), 0, self.T - 1))] = np.asarray(v, float)
        kt = np.array(sorted(keys))
        kv = np.array([keys[t] for t in kt])
        return spline(np.arange(self.T, dtype=float), kt, kv, 0.3)
