"""Event planners: stepping bouts, turns, gestures and plain standing."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from pipeline.sim.blind3.kin import D2R
from pipeline.sim.blind3.model import KA_MIN, V_SHIFT, V_SWING, FloatArray, Intent, SeqGen, Tracks, keycurve


def lerp(a: ArrayLike, b: ArrayLike, t: float) -> FloatArray:
    """a + (b - a) t."""
    return np.asarray(a) + (np.asarray(b) - np.asarray(a)) * t


class Generator(SeqGen):
    """One sequence: ``run()`` plans and simulates the timeline, ``assemble()`` gives the joints."""

    cur: int  # ev_side: the frame its planning has reached

    # ================================================================ timeline
    def run(self) -> Generator:
        R = self.rng
        T = self.T
        f = self.ev_idle(0, self.U(1.0, 2.5))
        while T - f >= self.sec(3.5):
            fmax = T - self.sec(0.5)
            r = R.random()
            if r < 0.46:
                f = self.ev_march(f, fmax)
            else:
                # left / right equally likely, nudged towards the side used less so far by this kind
                kind = str(R.choice(["side-step-out-back", "step-touch", "shuffle"], p=[0.4, 0.35, 0.25]))
                same = [b for b in self.bouts if b["kind"] == kind]
                if not same:  # first bout of this kind: alternate the side over sequences
                    ki = ["side-step-out-back", "step-touch", "shuffle"].index(kind)
                    p_right = 0.85 if (self.idx + ki) % 2 == 0 else 0.15
                else:
                    nl = sum(1 for b in same if b["direction"] == "left")
                    nr = sum(1 for b in same if b["direction"] == "right")
                    p_right = 0.5 if nl == nr else (0.75 if nr < nl else 0.25)
                d = 1 if R.random() < p_right else -1
                f = self.ev_side(f, fmax, d, kind)
            if T - f < self.sec(0.6):
                break
            f = self.standing_phase(f, T)
        if f < T:
            self.ev_idle(f, (T - f) / self.fps + 1.0)
        return self

    def standing_phase(self, f: int, fmax: int) -> int:
        R = self.rng
        avail = (fmax - f) / self.fps
        if R.random() < 0.25:
            self.set_carriage(f)
        if R.random() < 0.4 or avail < 4.0:
            return self.ev_idle(f, min(self.U(0.6, 2.0), avail))
        f = self.ev_idle(f, self.U(0.3, 1.0))
        n_act = 1 if R.random() < 0.7 else 2
        kinds = ["turn", "look", "wave", "point", "weight-shift", "stretch", "bow"]
        probs = np.array([0.25, 0.17, 0.12, 0.12, 0.14, 0.10, 0.10])
        for _ in range(n_act):
            kind = str(R.choice(kinds, p=probs))
            fn = {"turn": self.ev_turn, "weight-shift": self.ev_shift, "bow": self.ev_bow}.get(kind)
            if fn is not None:
                f2 = fn(f, fmax - self.sec(0.4))
            else:
                f2 = self.ev_gesture(f, fmax - self.sec(0.4), kind)
            if f2 is None:
                break
            f = f2
            f = self.ev_idle(f, min(self.U(0.3, 1.2), (fmax - f) / self.fps))
        return f

    # ================================================================ helpers
    def shift(
        self,
        tr: Tracks,
        intent: Intent,
        f: int,
        C: FloatArray,
        primary: int,
        ka_p: float | None = None,
        beta: float | None = None,
        lst: float = 0.0,
        heel: Sequence[float] = (0.0, 0.0),
        vmax: float | None = V_SHIFT,
    ) -> int:
        """Double-support key pose (weight shift); returns the frame actually used."""
        return self.pose(
            tr, f, intent, C, [0, 1], primary, ka_p=ka_p, beta=beta, lst=lst, heel=heel, vmax=vmax
        )

    def do_step(
        self,
        tr: Tracks,
        intent: Intent,
        s: int,
        f_lo: int,
        nT: int,
        land_xy: FloatArray,
        land_yaw: float,
        C_mid: FloatArray,
        C_td: FloatArray,
        A_h: float,
        A_k: float,
        ka_st: float,
        lst_mid: float = 0.0,
        psi_td: float | None = None,
        up: tuple[float, float] = (0.45, 0.4),
        lat: tuple[float, float] = (0.2, 0.8),
        kind: str = "",
    ) -> int:
        """One step of leg s lifting off after frame f_lo (the last key pose, both feet down) and
        landing at land_xy.  The touch-down key pose is computed first; the step is lengthened
        if the pelvis would have to travel faster than V_SWING; the stance leg gets a mid-swing
        key half-way (plus the requested sway bias).  Returns the touch-down frame."""
        B = self.B
        o = 1 - s
        assert intent.last_f == f_lo, (intent.last_f, f_lo)
        C_lo = intent.last_p.copy()
        psi_lo = intent.psi
        psi_new = intent.psi if psi_td is None else psi_td
        intent.F[s, :2] = land_xy
        intent.F[s, 2] = B.ankle_h
        intent.Y[s] = land_yaw
        # a wide step drags the pelvis towards the landing foot
        C_td = np.array(C_td, float)
        hoff = self.hip_off(psi_new, 0.0)
        rmax = 0.4 * (B.L1 + B.L2)

        def excess(C: FloatArray, foot: FloatArray, leg: int) -> tuple[FloatArray, float]:
            d = np.asarray(foot[:2]) - (C + hoff[leg][:2])
            n = float(np.linalg.norm(d))
            return d, n - rmax

        d, ex = excess(C_td, land_xy, s)
        if ex > 0:
            C_new = C_td + d / np.linalg.norm(d) * ex
            if excess(C_new, intent.F[o], o)[1] > 0:
                C_new = 0.5 * (C_new + C_td)
            C_td = C_new
        _ang, p_td, _ = self.pose_geom(intent, C_td, [0, 1], o, ka_st, 0.0, (0.0, 0.0), psi_new)
        travel = float(np.linalg.norm(p_td[:2] - C_lo))
        nT = max(nT, math.ceil(travel / V_SWING * self.fps))
        f_td = f_lo + nT
        fm = f_lo + nT // 2
        if psi_td is not None:
            tr["psi"].key(f_lo, psi_lo)
            tr["psi"].key(f_td, psi_td)
        intent.psi = psi_new
        self.pose(tr, f_td, intent, C_td, [0, 1], o, ka_p=ka_st, vmax=None)
        # stance-leg mid-swing key: half-way pelvis plus (bounded) requested sway towards the stance foot
        half = 0.5 * (C_lo + intent.last_p)
        bias = np.asarray(C_mid[:2]) - 0.5 * (C_lo + np.asarray(C_td[:2]))
        nb = np.linalg.norm(bias)
        if nb > 0.03:
            bias *= 0.03 / nb
        self.pose(
            tr,
            fm,
            intent,
            half + bias,
            [o],
            o,
            ka_p=ka_st,
            lst=lst_mid,
            psi=0.5 * (psi_lo + psi_new),
            record=False,
        )
        self.add_swing(
            tr,
            s,
            f_lo,
            f_td,
            A_h,
            A_k,
            up_h=up[0],
            up_k=up[1],
            lat=lat,
            kind=kind,
            min_clear=0.025 if kind == "shuffle" else 0.03,
        )
        return f_td

    def add_neck(self, ch: int, fa: int, keys: Sequence[tuple[int, float]], n: int) -> None:
        """Add a key-framed curve (zero at both ends) to neck channel ch (yaw, pitch, roll)."""
        n = min(n, self.T - fa)
        if n > 2:
            ends = [(0, 0.0)] + [(min(max(k, 1), n - 2), v) for k, v in keys] + [(n - 1, 0.0)]
            self.neck[fa : fa + n, ch] += keycurve(n, ends)

    def add_spine(self, j: int, ch: int, fa: int, keys: Sequence[tuple[int, float]], n: int) -> None:
        """Add a key-framed curve to spine joint j (lumbar, thoracic), channel ch (flexion, bend, twist)."""
        n = min(n, self.T - fa)
        if n > 2:
            ends = [(0, 0.0)] + [(min(max(k, 1), n - 2), v) for k, v in keys] + [(n - 1, 0.0)]
            self.spine[fa : fa + n, j, ch] += keycurve(n, ends)

    def glance(self, fa: int, n: int) -> None:
        """Short look-around (head + a little trunk twist) inside n frames."""
        R = self.rng
        if n < 8:
            return
        yaw = R.choice([-1, 1]) * self.U(15, 60) * D2R
        pitch = self.U(-12, 12) * D2R
        k1 = max(2, int(n * 0.3))
        k2 = max(k1 + 1, int(n * 0.7))
        self.add_neck(0, fa, [(k1, yaw), (k2, yaw * 0.9)], n)
        self.add_neck(1, fa, [(k1, pitch), (k2, pitch)], n)
        self.add_spine(1, 2, fa, [(k1, 0.2 * yaw), (k2, 0.2 * yaw)], n)

    # ================================================================ standing
    def ev_idle(self, f0: int, dur: float, tag: str = "") -> int:
        f1 = min(self.T, f0 + max(3, self.sec(dur)))
        tr, intent = self.begin(f0)
        prim = int(self.rng.integers(2))
        _, p, _ = self.pose_geom(
            intent, intent.mid(), [0, 1], prim, self.B.knee0, 0.0, (0.0, 0.0), intent.psi
        )
        travel = float(np.linalg.norm(p[:2] - intent.last_p))
        k = min(f0 + max(self.sec(self.U(0.3, 0.5)), math.ceil(travel / 0.3 * self.fps)), f1 - 3)
        if k >= f0:
            self.pose(tr, k, intent, intent.mid(), [0, 1], prim, beta=0.5, vmax=None)
            tr["tilt"].key(k, 0.0)
        self.tags[f0:f1] = tag
        self.events.append(dict(kind="idle", f0=f0, f1=f1))
        return self.end(tr, f0, f1)

    def ev_shift(self, f0: int, fmax: int) -> int | None:
        R, B = self.rng, self.B
        segs: list[dict[str, Any]] = []
        k = int(R.integers(2))
        for _i in range(1 if R.random() < 0.65 else 2):
            segs.append(
                dict(
                    k=k,
                    ramp=self.sec(self.U(0.3, 0.8)),
                    hold=self.sec(self.U(0.8, 2.5)),
                    frac=self.U(0.5, 0.95),
                    lst=self.U(2, 5) * D2R,
                    heel=self.U(12, 30) * D2R if R.random() < 0.4 else 0.0,
                )
            )
            k = 1 - k
        back = self.sec(self.U(0.3, 0.7))
        total = sum(s["ramp"] + s["hold"] for s in segs) + back + 3
        if f0 + total > fmax:
            return None
        tr, intent = self.begin(f0)
        f = f0
        nheel = 0
        for sg in segs:
            k = sg["k"]
            u = 1 - k
            f += sg["ramp"]
            C = lerp(intent.mid(), intent.F[k, :2], sg["frac"])
            lst = sg["lst"] if u == 1 else -sg["lst"]
            ka = max(2 * KA_MIN, B.knee0 - self.U(0, 3) * D2R)
            bt = self.U(0.9, 1.0)
            beta = bt if k == 1 else 1 - bt
            f = self.shift(tr, intent, f, C, k, ka_p=ka, beta=beta, lst=lst)
            if sg["heel"] > 0 and sg["hold"] > self.sec(1.0):
                h = [0.0, 0.0]
                h[u] = sg["heel"]
                a0 = f + self.sec(self.U(0.1, 0.3))
                a1 = a0 + self.sec(self.U(0.25, 0.45))
                a3 = f + sg["hold"] - self.sec(self.U(0.05, 0.2))
                a2 = a3 - self.sec(self.U(0.25, 0.45))
                if a2 > a1:
                    self.shift(tr, intent, a0, C, k, ka_p=ka, beta=beta, lst=lst)
                    self.shift(tr, intent, a1, C, k, ka_p=ka, beta=beta, lst=lst, heel=h)
                    self.shift(tr, intent, a2, C, k, ka_p=ka, beta=beta, lst=lst, heel=h)
                    self.shift(tr, intent, a3, C, k, ka_p=ka, beta=beta, lst=lst)
                    nheel += 1
            f += sg["hold"]
            f = self.shift(tr, intent, f, C, k, ka_p=ka, beta=beta, lst=lst)
        f += back
        f = self.shift(tr, intent, f, intent.mid(), int(R.integers(2)), beta=0.5)
        f1 = f + 3
        self.tags[f0:f1] = "weight-shift"
        self.events.append(dict(kind="weight-shift", f0=f0, f1=f1, n_shifts=len(segs), heel_lifts=nheel))
        return self.end(tr, f0, f1, still_sway=False)

    def ev_bow(self, f0: int, fmax: int) -> int | None:
        B = self.B
        nd, nh, nu = self.sec(self.U(0.5, 0.9)), self.sec(self.U(0.3, 1.0)), self.sec(self.U(0.5, 0.9))
        n = nd + nh + nu + self.sec(0.2)
        if f0 + n + 3 > fmax:
            return None
        tr, intent = self.begin(f0)
        psi = intent.psi
        ey = np.array([-math.sin(psi), math.cos(psi)])
        tilt = self.U(12, 32) * D2R
        back = self.U(0.02, 0.05)
        fa = f0 + self.sec(0.1)
        C0 = intent.mid()
        ka = B.knee0 + self.U(0, 4) * D2R
        fa = self.shift(tr, intent, fa, C0, 0, beta=0.5)
        tr["tilt"].key(fa, 0.0)
        fb = self.shift(tr, intent, fa + nd, C0 - back * ey, 0, ka_p=ka, beta=0.5)
        tr["tilt"].key(fb, tilt)
        fc = self.shift(tr, intent, fb + nh, C0 - back * ey, 0, ka_p=ka, beta=0.5)
        tr["tilt"].key(fc, tilt)
        fd = self.shift(tr, intent, fc + nu, C0, 0, beta=0.5)
        tr["tilt"].key(fd, 0.0)
        nd, nh, nu = fb - fa, fc - fb, fd - fc
        f1 = fd + 3
        lum, tho, nk = self.U(5, 15) * D2R, self.U(5, 12) * D2R, self.U(10, 25) * D2R
        m = nd + nh + nu
        self.add_spine(0, 0, fa, [(nd, lum), (nd + nh, lum)], m)
        self.add_spine(1, 0, fa, [(nd, tho), (nd + nh, tho)], m)
        self.add_neck(1, fa, [(nd, nk), (nd + nh, nk)], m)
        self.tags[f0:f1] = "bow"
        self.events.append(dict(kind="bow", f0=f0, f1=f1, depth_deg=(tilt + lum + tho) / D2R))
        return self.end(tr, f0, f1)

    def ev_gesture(self, f0: int, fmax: int, kind: str) -> int | None:
        R, B = self.rng, self.B
        fa = f0 + self.sec(self.U(0.05, 0.3))
        info: dict[str, Any] = dict(kind=kind)
        if kind == "wave":
            side = B.handed if R.random() < 0.85 else 1 - B.handed
            nu, nh, nd = self.sec(self.U(0.4, 0.7)), self.sec(self.U(1.0, 3.0)), self.sec(self.U(0.4, 0.7))
            if R.random() < 0.65:
                pose = np.array([0, self.U(70, 100), self.U(0, 25), self.U(70, 95), self.U(60, 100)]) * D2R
                osc = (4, self.U(15, 30) * D2R, self.U(1.5, 3.0))
                info["style"] = "elbow"
            else:
                pose = np.array([0, self.U(130, 160), self.U(0, 20), self.U(0, 20), self.U(10, 30)]) * D2R
                osc = (1, self.U(10, 20) * D2R, self.U(1.2, 2.5))
                info["style"] = "overhead"
            n = nu + nh + nd
            if fa + n + 3 > fmax:
                return None
            self.gesture_arm(side, fa, nu, nh, nd, pose, osc)
            yaw = self.U(-25, 25) * D2R
            self.add_neck(0, fa, [(nu, yaw), (nu + nh, yaw)], n)
            self.add_spine(1, 1, fa, [(nu, (4 if side == 0 else -4) * D2R), (nu + nh, 0.0)], n)
            info["side"] = "left" if side == 0 else "right"
        elif kind == "point":
            n = 0
            items: list[tuple[int, int, int, int]] = []
            for _i in range(1 if R.random() < 0.7 else 2):
                side = B.handed if R.random() < 0.75 else 1 - B.handed
                nu, nh, nd = (
                    self.sec(self.U(0.3, 0.6)),
                    self.sec(self.U(0.6, 2.0)),
                    self.sec(self.U(0.4, 0.7)),
                )
                items.append((side, nu, nh, nd))
                n += nu + nh + nd
            if fa + n + 3 > fmax:
                return None
            f = fa
            for side, nu, nh, nd in items:
                h = self.U(-45, 50)
                flex = self.U(70, 100)
                pose = np.array([h, self.U(0, 10), flex, self.U(-10, 10), self.U(0, 15)]) * D2R
                self.gesture_arm(side, f, nu, nh, nd, pose)
                yaw = (h if side == 0 else -h) * 0.8 * D2R
                m = nu + nh + nd
                self.add_neck(0, f, [(nu, yaw), (nu + nh, yaw)], m)
                self.add_neck(1, f, [(nu, (90 - flex) * 0.4 * D2R), (nu + nh, (90 - flex) * 0.4 * D2R)], m)
                self.add_spine(1, 2, f, [(nu, 0.25 * yaw), (nu + nh, 0.25 * yaw)], m)
                f += m
            info["n_points"] = len(items)
        elif kind == "stretch":
            nu, nh, nd = self.sec(self.U(0.6, 1.0)), self.sec(self.U(0.8, 2.5)), self.sec(self.U(0.6, 1.0))
            n = nu + nh + nd
            if fa + n + 3 > fmax:
                return None
            style = str(R.choice(["overhead", "arms-out", "side-bend"], p=[0.5, 0.25, 0.25]))
            for side in (0, 1):
                if style == "arms-out":
                    pose = np.array([0, self.U(80, 95), self.U(0, 15), 0, self.U(0, 10)]) * D2R
                else:
                    pose = np.array([0, self.U(10, 30), self.U(150, 172), 0, self.U(5, 20)]) * D2R
                self.gesture_arm(side, fa, nu, nh, nd, pose)
            if style == "side-bend":
                lat = R.choice([-1, 1]) * self.U(8, 18) * D2R
                self.add_spine(0, 1, fa, [(nu, 0.4 * lat), (nu + nh, 0.4 * lat)], n)
                self.add_spine(1, 1, fa, [(nu, 0.6 * lat), (nu + nh, 0.6 * lat)], n)
            else:
                ext = -self.U(3, 8) * D2R
                self.add_spine(0, 0, fa, [(nu, ext), (nu + nh, ext)], n)
                self.add_neck(1, fa, [(nu, -self.U(5, 15) * D2R), (nu + nh, -self.U(5, 15) * D2R)], n)
            info["style"] = style
        elif kind == "look":
            keys_y: list[tuple[int, float]] = []
            keys_p: list[tuple[int, float]] = []
            k = 0
            for _i in range(int(R.integers(1, 4))):
                k += self.sec(self.U(0.2, 0.45))
                y = R.choice([-1, 1]) * self.U(25, 75) * D2R
                p = self.U(-20, 20) * D2R
                keys_y.append((k, y))
                keys_p.append((k, p))
                k += self.sec(self.U(0.4, 1.5))
                keys_y.append((k, y))
                keys_p.append((k, p))
            n = k + self.sec(self.U(0.3, 0.5))
            if fa + n + 3 > fmax:
                return None
            self.add_neck(0, fa, keys_y, n)
            self.add_neck(1, fa, keys_p, n)
            self.add_spine(1, 2, fa, [(kk, 0.25 * v) for kk, v in keys_y], n)
            self.add_spine(0, 2, fa, [(kk, 0.1 * v) for kk, v in keys_y], n)
            info["n_fixations"] = len(keys_y) // 2
        f1 = fa + n + 3
        self.ev_idle(f0, (f1 - f0) / self.fps, tag=kind)
        self.events[-1] = dict(info, f0=f0, f1=f1)
        return f1

    # ================================================================ turning on the spot
    def ev_turn(self, f0: int, fmax: int) -> int | None:
        R, B = self.rng, self.B
        sign = 1 if R.random() < 0.5 else -1
        delta = sign * (self.U(30, 90) if R.random() < 0.6 else self.U(90, 180)) * D2R
        n_pairs = math.ceil(abs(delta) / (self.U(35, 50) * D2R))
        di = delta / n_pairs
        lead = 0 if delta > 0 else 1
        trail = 1 - lead
        a = self.U(0.5, 0.65)
        plan: list[tuple[int, int, int, int]] = []
        for _k in range(n_pairs):
            plan.append(
                (
                    self.sec(self.U(0.35, 0.6)),
                    self.sec(self.U(0.1, 0.25)),
                    self.sec(self.U(0.3, 0.55)),
                    self.sec(self.U(0.1, 0.25)),
                )
            )
        pre = self.sec(self.U(0.25, 0.5))
        total = pre + sum(sum(p) for p in plan) + self.sec(0.3) + 3
        if f0 + total > fmax:
            return None
        tr, intent = self.begin(f0)
        Cc = intent.mid() * 0.95
        sfrac = self.U(0.2, 0.4)
        f = f0 + pre
        f = self.shift(tr, intent, f, lerp(Cc, intent.F[trail, :2], sfrac), trail)
        ka = B.knee0 + self.U(0, 4) * D2R
        for k, (n1, g1, n2, g2) in enumerate(plan):
            psi0 = intent.psi
            A_h, A_k = self.U(6, 16) * D2R, self.U(18, 32) * D2R
            psi1 = psi0 + a * di
            Fh, Yh = self.home(Cc, psi1)
            C = lerp(Cc, intent.F[trail, :2], sfrac)
            f = self.do_step(
                tr,
                intent,
                lead,
                f,
                n1,
                Fh[lead] + R.normal(0, 0.01, 2),
                Yh[lead],
                C,
                C,
                A_h,
                A_k,
                ka,
                psi_td=psi1,
                kind="turn",
            )
            f += g1
            f = self.shift(tr, intent, f, lerp(Cc, intent.F[lead, :2], sfrac), lead, ka_p=ka)
            psi2 = psi0 + di
            Fh, Yh = self.home(Cc, psi2)
            C = lerp(Cc, intent.F[lead, :2], sfrac)
            A_h, A_k = self.U(6, 16) * D2R, self.U(18, 32) * D2R
            f = self.do_step(
                tr,
                intent,
                trail,
                f,
                n2,
                Fh[trail] + R.normal(0, 0.01, 2),
                Yh[trail],
                C,
                C,
                A_h,
                A_k,
                ka,
                psi_td=psi2,
                kind="turn",
            )
            f += g2
            if k < n_pairs - 1:
                f = self.shift(tr, intent, f, lerp(Cc, intent.F[trail, :2], sfrac), trail, ka_p=ka)
        f += self.sec(0.3)
        f = self.shift(tr, intent, f, intent.mid(), 0, beta=0.5)
        f1 = f + 3
        # the head leads the turn, the trunk follows a little
        n = f1 - f0
        hy = sign * self.U(15, 30) * D2R
        self.add_neck(0, f0, [(pre, hy), (int(n * 0.7), hy * 0.5)], n)
        self.add_spine(1, 2, f0, [(pre, 0.3 * hy), (int(n * 0.7), 0.15 * hy)], n)
        self.tags[f0:f1] = "turn"
        self.events.append(dict(kind="turn", f0=f0, f1=f1, angle_deg=delta / D2R, pivot_steps=2 * n_pairs))
        return self.end(tr, f0, f1, still_sway=False)

    # ================================================================ forward: marching in place
    def ev_march(self, f0: int, fmax: int) -> int:
        R, B = self.rng, self.B
        fps = self.fps
        if not any(b["kind"] == "march" for b in self.bouts):
            # first marching bout of a sequence: cadence stratified over blocks of 12 sequences
            k = np.random.default_rng([self.seed, 998]).permutation(12)[self.idx % 12]
            c = 0.5 + 2.1 * (k + self.U(0.1, 0.9)) / 12
        else:
            c = self.U(1.0, 2.2) if R.random() < 0.4 else self.U(0.5, 2.6)
        level = R.random()
        if c > 2.0:
            level *= 0.6
        th_pk = (12 + 63 * level) * D2R
        ka_extra = self.U(5, 30) * D2R
        us = self.U(0.6, 0.82)
        asym = np.ones(2)
        if R.random() < 0.5:
            asym[int(R.integers(2))] = self.U(0.75, 0.97)
        n_plan = int(np.clip(round(R.lognormal(math.log(8), 0.55)), 2, 30))
        n_plan = min(n_plan, max(2, int(16 * c)))
        p_pause = float(R.choice([0.0, 0.0, 0.08, 0.2]))
        swing_arms = R.random() < 0.6
        arm_amp = self.U(8, 35) * (0.5 + 0.5 * level) if swing_arms else 0.0
        sway = self.U(0.15, 0.45) * float(np.clip(1.4 / c, 0.4, 1.0))
        hike = self.U(-1, 4) * D2R
        lean = self.U(0, 6) * level * D2R
        if R.random() < 0.4:
            self.set_carriage(f0)
        tr, intent = self.begin(f0)
        psi = intent.psi
        ka_st = B.knee0
        s = int(R.integers(2))
        f = f0 + self.sec(self.U(0.15, 0.4))
        f = self.shift(tr, intent, f, lerp(intent.mid(), intent.F[1 - s, :2], sway), 1 - s, ka_p=ka_st)
        P = 1.0 / c
        tempo = 1.0
        first_lo, last_td = f, None
        steps: list[dict[str, Any]] = []
        pauses: list[tuple[int, int]] = []
        i = 0
        while i < n_plan:
            tempo = float(np.clip(tempo * math.exp(R.normal(0, 0.03)), 0.85, 1.15))
            Pi = P * tempo * (1 + R.normal(0, 0.05))
            Ts = min(us * Pi, 1.3)
            nT = max(5, round(Ts * fps))
            if f + nT + self.sec(0.7) > fmax:
                break
            o = 1 - s
            amp = asym[s] * self.U(0.85, 1.15)
            if R.random() < 0.05:
                amp *= 0.5
            A_h = th_pk * amp
            A_k = A_h + ka_extra * self.U(0.8, 1.2)
            Cc = intent.mid() * 0.92
            Fh, Yh = self.home(Cc, psi)
            land = 0.5 * intent.F[s, :2] + 0.5 * Fh[s] + R.normal(0, 0.008, 2)
            if R.random() < 0.04:
                land = land + R.normal(0, 0.025, 2)
            mid_after = 0.5 * (land + intent.F[o, :2])
            C_mid = lerp(intent.mid(), intent.F[o, :2], sway * 1.15)
            C_td = lerp(mid_after, intent.F[o, :2], sway * 0.9)
            up_h = self.U(0.4, 0.52)
            f_td = self.do_step(
                tr,
                intent,
                s,
                f,
                nT,
                land,
                Yh[s] + R.normal(0, 2) * D2R,
                C_mid,
                C_td,
                A_h,
                A_k,
                ka_st,
                lst_mid=hike if s == 0 else -hike,
                up=(up_h, up_h - self.U(0, 0.08)),
                kind="march",
            )
            steps.append(dict(foot=s, f_lo=f, f_td=f_td, hip_flex_deg=A_h / D2R))
            last_td = f_td
            i += 1
            if i >= n_plan:
                break
            if R.random() < p_pause:
                pl = self.U(0.2, 1.0)
                f_next = f_td + max(self.sec(pl), 6)
                s_next = o if R.random() < 0.7 else s
                if f_next - f_td >= 10:
                    self.pose(
                        tr,
                        f_td + int(0.4 * (f_next - f_td)),
                        intent,
                        lerp(intent.last_p, intent.mid(), 0.7),
                        [0, 1],
                        o,
                        ka_p=ka_st,
                        beta=0.5,
                        vmax=None,
                    )
                if R.random() < 0.5:
                    self.glance(f_td + 1, f_next - f_td)
                is_pause = True
            else:
                Td = max(Pi - Ts, 2.0 / fps) * self.U(0.9, 1.1)
                if R.random() < 0.04:
                    Td += self.U(0.1, 0.25)
                f_next = f_td + max(2, round(Td * fps))
                s_next = o
                is_pause = False
            if f_next + self.sec(0.4) + self.sec(0.7) > fmax:
                break
            ns = 1 - s_next
            f_next = self.shift(
                tr, intent, f_next, lerp(intent.mid(), intent.F[ns, :2], sway), ns, ka_p=ka_st, vmax=0.5
            )
            if is_pause:
                pauses.append((f_td + 1, f_next))
            f = f_next
            s = s_next
        assert last_td is not None, "a bout has at least one step"
        f_end = max(last_td + self.sec(self.U(0.3, 0.6)), intent.last_f + self.sec(0.3))
        f_end = self.shift(tr, intent, f_end, intent.mid(), int(R.integers(2)), beta=0.5)
        f1 = f_end + 3
        self.labels[first_lo + 1 : last_td + 1] = "forward"
        self.tags[first_lo + 1 : last_td + 1] = "march"
        for a, b in pauses:
            self.tags[a : b + 1] = "pause"
        # arm swing gain (deg shoulder flexion per deg of hip flexion difference), trunk lean
        gain = arm_amp / (th_pk / D2R) * (0.4 if self.carr_mode == "controllers" else 1.0)
        env = np.ones(f1 - f0)
        k0 = first_lo - f0
        env[:k0] = 0
        self.armswing[f0:f1] = gain * env
        self.add_spine(0, 0, f0, [(k0, lean), (last_td - f0, lean)], f1 - f0)
        self.add_neck(1, f0, [(k0, -0.8 * lean), (last_td - f0, -0.8 * lean)], f1 - f0)
        dur = (last_td - first_lo) / fps
        pause_t = sum(b - a + 1 for a, b in pauses) / fps
        self.bouts.append(
            dict(
                kind="march",
                direction="forward",
                f_start=first_lo + 1,
                f_end=last_td,
                n_steps=len(steps),
                nominal_cadence=c,
                duration=dur,
                pauses=[(b - a + 1) / fps for a, b in pauses],
                cadence=(len(steps) / max(dur - pause_t, 1e-6)),
                knee_lift_level=level,
                peak_hip_flex_deg=th_pk / D2R,
                arm_swing=bool(swing_arms),
                arm_amp_deg=arm_amp,
                steps=steps,
            )
        )
        self.events.append(dict(kind="march", f0=f0, f1=f1))
        return self.end(tr, f0, f1, still_sway=False)

    # ================================================================ left / right: side steps
    def side_need(self, kind: str, m: int) -> int:
        """Upper bound (frames) of one repetition incl. anticipation and settling."""
        if kind == "shuffle":
            t = 4 * m * 0.3 + (4 * m + 1) * 0.18
        elif kind == "step-touch":
            t = 4 * 0.55 + 3 * 0.35 + 0.35
        else:
            t = 2 * 0.55 + 2 * 0.35 + 0.5
        return self.sec(t + 0.7 + 0.35)

    def ev_side(self, f0: int, fmax: int, d: int, kind: str) -> int:
        R, B = self.rng, self.B
        fps = self.fps
        lead = 1 if d > 0 else 0
        trail = 1 - lead
        m = 1
        if kind == "shuffle":
            w = self.U(0.08, 0.20)
            m = int(R.integers(1, 4))
            while m > 1 and (m * w > 0.45 or f0 + self.side_need(kind, m) > fmax):
                m -= 1
        if f0 + self.side_need(kind, m) > fmax:
            kind = "side-step-out-back"
        if f0 + self.side_need(kind, m) > fmax:
            return self.ev_idle(f0, (fmax - f0) / fps)
        if kind == "shuffle":
            reps = 1

            def lift() -> tuple[float, float]:
                return (self.U(3, 9) * D2R, self.U(20, 30) * D2R)

            def tstep() -> int:
                return self.sec(self.U(0.18, 0.3))

            def ttrans() -> int:
                return max(2, self.sec(self.U(0.08, 0.18)))
        else:
            w = self.U(0.12, 0.44) if kind == "side-step-out-back" else self.U(0.12, 0.40)
            reps = int(R.choice([1, 1, 2, 2, 3, 4]))

            def lift() -> tuple[float, float]:
                return (self.U(6, 20) * D2R, self.U(20, 40) * D2R)

            def tstep() -> int:
                return self.sec(self.U(0.3, 0.55))

            def ttrans() -> int:
                return self.sec(self.U(0.15, 0.35))

        if R.random() < 0.3:
            self.set_carriage(f0)
        tr, intent = self.begin(f0)
        psi = intent.psi
        ex = np.array([math.cos(psi), math.sin(psi)])
        ey = np.array([-math.sin(psi), math.cos(psi)])
        Cc = intent.mid() * 0.92
        Fh, Yh = self.home(Cc, psi)
        ka_st = B.knee0
        gap_touch = self.U(0.09, 0.14) * B.H / 1.75
        p_pause = self.U(0.15, 0.6)
        sway = self.U(0.2, 0.45)
        f = f0 + self.sec(self.U(0.15, 0.35))
        f = self.shift(tr, intent, f, lerp(intent.mid(), intent.F[trail, :2], sway), trail, ka_p=ka_st)
        first_lo = f
        last_td: int | None = None
        steps: list[dict[str, Any]] = []
        pauses: list[tuple[int, int]] = []
        widths: list[float] = []

        def step(
            s: int,
            nT: int,
            land: FloatArray,
            C_mid: FloatArray,
            C_td: FloatArray,
            ka: float = ka_st,
            lat: tuple[float, float] = (0.2, 0.8),
        ) -> int:
            nonlocal last_td
            A_h, A_k = lift()
            f_lo = self.cur
            yaw = Yh[s] + R.normal(0, 2) * D2R
            f_td = self.do_step(
                tr, intent, s, f_lo, nT, land, yaw, C_mid, C_td, A_h, A_k, ka, lat=lat, kind=kind
            )
            steps.append(dict(foot=s, f_lo=f_lo, f_td=f_td))
            last_td = f_td
            self.cur = f_td
            return f_td

        def over(s: int, frac: float) -> FloatArray:
            """pelvis centre when fraction frac of the way from the foot midpoint to foot s"""
            return lerp(intent.mid(), intent.F[s, :2], frac)

        self.cur = f
        done_reps = 0
        for r in range(reps):
            wr = w * (self.U(0.9, 1.1) if r > 0 else 1.0)
            need = self.side_need(kind, m)
            if r > 0 and self.cur + need > fmax:
                break
            if kind == "side-step-out-back":
                out = Fh[lead] + d * wr * ex + R.normal(0, 0.012, 2)
                C = over(trail, sway * 1.1)
                step(lead, tstep(), out, C, C)
                widths.append(float(np.dot(out - Fh[lead], ex) * d))
                fw = self.U(0.35, 0.8)
                self.cur += ttrans()
                kb = ka_st + self.U(2, 8) * D2R
                Cw = lerp(intent.F[trail, :2], intent.F[lead, :2], fw)
                prim = lead if fw > 0.5 else trail
                self.cur = self.shift(
                    tr, intent, self.cur, Cw, prim, ka_p=kb, beta=fw if lead == 1 else 1 - fw
                )
                self.cur += self.sec(self.U(0.0, 0.5))
                self.cur = self.shift(
                    tr, intent, self.cur, Cw, prim, ka_p=kb, beta=fw if lead == 1 else 1 - fw
                )
                self.cur += ttrans()
                C = lerp(intent.F[trail, :2], intent.F[lead, :2], self.U(0.05, 0.2))
                self.cur = self.shift(tr, intent, self.cur, C, trail, ka_p=ka_st)
                back = Fh[lead] + R.normal(0, 0.008, 2)
                step(
                    lead,
                    tstep(),
                    back,
                    C,
                    lerp(0.5 * (back + intent.F[trail, :2]), intent.F[trail, :2], sway),
                )
            elif kind == "step-touch":
                out = Fh[lead] + d * wr * ex + R.normal(0, 0.012, 2)
                C = over(trail, sway * 1.1)
                step(lead, tstep(), out, C, C)
                widths.append(float(np.dot(out - Fh[lead], ex) * d))
                self.cur += ttrans()
                C = lerp(intent.mid(), intent.F[lead, :2], self.U(0.75, 0.95))
                self.cur = self.shift(tr, intent, self.cur, C, lead)
                touch = intent.F[lead, :2] - d * gap_touch * ex + R.normal(0, 0.01) * ey
                step(trail, tstep(), touch, C, C)
                self.cur += self.sec(self.U(0.1, 0.35))
                self.cur = self.shift(tr, intent, self.cur, C, lead)
                back_t = Fh[trail] + R.normal(0, 0.008, 2)
                step(trail, tstep(), back_t, C, C)
                self.cur += ttrans()
                C = lerp(intent.F[lead, :2], intent.F[trail, :2], self.U(0.8, 0.95))
                self.cur = self.shift(tr, intent, self.cur, C, trail)
                back_l = Fh[lead] + R.normal(0, 0.008, 2)
                step(
                    lead,
                    tstep(),
                    back_l,
                    C,
                    lerp(0.5 * (back_l + intent.F[trail, :2]), intent.F[trail, :2], sway),
                )
            else:  # shuffle: m low quick lead/trail pairs out, then m pairs back
                for j in range(1, m + 1):
                    out = Fh[lead] + d * j * w * ex + R.normal(0, 0.006, 2)
                    C = over(trail, sway)
                    step(lead, tstep(), out, C, C)
                    if j == 1:
                        widths.append(float(np.dot(out - Fh[lead], ex) * d))
                    self.cur += ttrans()
                    C = lerp(intent.F[trail, :2], intent.F[lead, :2], self.U(0.75, 0.9))
                    self.cur = self.shift(tr, intent, self.cur, C, lead)
                    fol = Fh[trail] + d * j * w * ex + R.normal(0, 0.006, 2)
                    step(trail, tstep(), fol, C, C)
                    self.cur += ttrans()
                    C = lerp(intent.F[lead, :2], intent.F[trail, :2], self.U(0.6, 0.85))
                    self.cur = self.shift(tr, intent, self.cur, C, trail)
                C = lerp(intent.F[trail, :2], intent.F[lead, :2], self.U(0.75, 0.9))
                self.cur += ttrans()
                self.cur = self.shift(tr, intent, self.cur, C, lead)
                for j in range(m - 1, -1, -1):
                    bt = Fh[trail] + d * j * w * ex + R.normal(0, 0.006, 2)
                    step(trail, tstep(), bt, C, C)
                    self.cur += ttrans()
                    C = lerp(intent.F[lead, :2], intent.F[trail, :2], self.U(0.75, 0.9))
                    self.cur = self.shift(tr, intent, self.cur, C, trail)
                    bl = Fh[lead] + d * j * w * ex + R.normal(0, 0.006, 2)
                    step(lead, tstep(), bl, C, C)
                    self.cur += ttrans()
                    if j > 0:
                        C = lerp(intent.F[trail, :2], intent.F[lead, :2], self.U(0.75, 0.9))
                        self.cur = self.shift(tr, intent, self.cur, C, lead)
            done_reps += 1
            if r < reps - 1:
                # between repetitions: a short re-set or a hesitation pause
                if R.random() < p_pause:
                    pl = max(self.sec(self.U(0.2, 1.0)), 6)
                    if self.cur + pl + need > fmax:
                        break
                    a = self.cur + 1
                    if pl >= 10:
                        self.pose(
                            tr,
                            self.cur + int(0.4 * pl),
                            intent,
                            lerp(intent.last_p, intent.mid(), 0.7),
                            [0, 1],
                            trail,
                            beta=0.5,
                            vmax=None,
                        )
                    if R.random() < 0.5:
                        self.glance(a, pl)
                    self.cur += pl
                    self.cur = self.shift(tr, intent, self.cur, over(trail, sway), trail, ka_p=ka_st)
                    pauses.append((a, self.cur))
                else:
                    self.cur += self.sec(self.U(0.1, 0.3))
                    self.cur = self.shift(tr, intent, self.cur, over(trail, sway), trail, ka_p=ka_st)
        assert last_td is not None, "a bout has at least one step"
        f_end = max(last_td + self.sec(self.U(0.3, 0.6)), intent.last_f + self.sec(0.3))
        f_end = self.shift(tr, intent, f_end, intent.mid(), int(R.integers(2)), beta=0.5)
        f1 = f_end + 3
        lab = "right" if d > 0 else "left"
        self.labels[first_lo + 1 : last_td + 1] = lab
        self.tags[first_lo + 1 : last_td + 1] = kind
        for a, b in pauses:
            self.tags[a : b + 1] = "pause"
        dur = (last_td - first_lo) / fps
        self.bouts.append(
            dict(
                kind=kind,
                direction=lab,
                f_start=first_lo + 1,
                f_end=last_td,
                n_steps=len(steps),
                reps=done_reps,
                shuffle_pairs=(m if kind == "shuffle" else None),
                width=float(np.mean(widths)),
                duration=dur,
                pauses=[(b - a + 1) / fps for a, b in pauses],
                steps=steps,
            )
        )
        self.events.append(dict(kind=kind, f0=f0, f1=f1))
        return self.end(tr, f0, f1, still_sway=False)
