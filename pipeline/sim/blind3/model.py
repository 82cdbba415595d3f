"""Joint-angle driven stepping-in-place generator.

The body is a skeletal hierarchy (pelvis root with position + yaw, pelvic list/tilt, two
spine joints, neck/head, shoulders+elbows, hips+knees).  Every event (a stepping bout, a
turn, a gesture, plain standing) writes *joint-angle* key frames; angles in between are
piecewise-cubic (PCHIP) curves plus analytic lift bumps for the swing legs.  Joint positions
come from forward kinematics.  The pelvis root is not animated: every frame it is placed so
that the weight-bearing ankle stays exactly where it was planted.  A second grounded foot is
kept on its plant point by a small closed-chain correction of that leg's hip/knee angles.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import PchipInterpolator
from scipy.ndimage import gaussian_filter1d

from pipeline.sim.blind3.body import height_for, sample_body
from pipeline.sim.blind3.kin import (
    D2R,
    Vec3,
    leg_angles_for,
    leg_fk,
    leg_len,
    mv,
    rot_x,
    rot_y,
    rot_z,
    wrap,
)

CONTACT, HEEL, SWING = 0, 1, 2
LEG_CH = ("th", "al", "rh", "ka")
KA_MIN = 1.0 * D2R
V_SHIFT = 0.30  # m/s: max mean pelvis speed of a weight shift (double support)
V_SWING = 0.45  # m/s: max mean pelvis speed during a step (single support)

FloatArray = NDArray[np.float64]
TrackKey = str | tuple[str, int]  # "psi", "lst", "tilt", "beta" or (leg channel or "heel", side)
Tracks = dict[TrackKey, "Track"]


def smoothstep(x: ArrayLike) -> Any:
    """3x^2 - 2x^3 of x clipped to [0, 1] (a float for a float, an array for an array)."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def keycurve(n: int, keys: Iterable[tuple[float, float]]) -> FloatArray:
    """PCHIP curve over frames 0..n-1 through keys [(frame, value)], held outside."""
    items = sorted({round(k): float(v) for k, v in keys}.items())
    fs = np.array([k for k, _ in items], float)
    vs = np.array([v for _, v in items], float)
    x = np.arange(n, dtype=float)
    if len(fs) == 1:
        return np.full(n, vs[0])
    y = PchipInterpolator(fs, vs, extrapolate=False)(x)
    y[x < fs[0]] = vs[0]
    y[x > fs[-1]] = vs[-1]
    return y


def envelope(n_up: int, n_hold: int, n_down: int) -> FloatArray:
    """Smooth rise over n_up frames, n_hold frames of 1, smooth fall over n_down frames."""
    up = smoothstep((np.arange(n_up) + 1) / (n_up + 1)) if n_up > 0 else np.zeros(0)
    dn = smoothstep(1.0 - (np.arange(n_down) + 1) / (n_down + 1)) if n_down > 0 else np.zeros(0)
    return np.concatenate([up, np.ones(n_hold), dn])


def smooth_noise(rng: np.random.Generator, T: int, fps: float, sd: float, fc: float) -> FloatArray:
    """T frames of Gaussian noise low-passed at about fc Hz, scaled to standard deviation sd."""
    x = rng.normal(size=T + 200)
    x = gaussian_filter1d(x, sigma=fps / (2 * math.pi * fc))[100 : 100 + T]
    return x / (x.std() + 1e-12) * sd


class Track:
    """Key frames {frame: value} of one channel; PCHIP in between, held outside."""

    def __init__(self, f0: int, v0: float) -> None:
        self.keys = {f0 - 2: float(v0), f0 - 1: float(v0)}

    def key(self, f: int, v: float) -> None:
        self.keys[int(f)] = float(v)

    def get(self, f: int) -> float:
        return self.keys[int(f)]

    def last_frame(self) -> int:
        return max(self.keys)

    def eval(self, f0: int, f1: int) -> FloatArray:
        fs = sorted(self.keys)
        vs = [self.keys[k] for k in fs]
        x = np.arange(f0, f1, dtype=float)
        y = PchipInterpolator(np.array(fs, float), np.array(vs), extrapolate=False)(x)
        y[x < fs[0]] = vs[0]
        y[x > fs[-1]] = vs[-1]
        return y


class Intent:
    """Planner's intended state (plant points, foot yaws, heading)."""

    def __init__(self, F: ArrayLike, Y: ArrayLike, psi: float) -> None:
        self.F = np.array(F, float)
        self.Y = np.array(Y, float)
        self.psi = float(psi)
        self.last_f: int = -10
        self.last_p: FloatArray = np.zeros(2)
        self.last_both = False
        self.last_beta, self.last_lst, self.last_psi = 0.5, 0.0, self.psi
        self.last_heel: tuple[float, ...] = (0.0, 0.0)

    def mid(self) -> FloatArray:
        return 0.5 * (self.F[0, :2] + self.F[1, :2])


class Swing:
    """One swing of leg s from lift-off f_lo (last frame down) to touch-down f_td."""

    __slots__ = ("K_app", "K_leave", "dz", "f_lo", "f_td", "fa", "kind", "plant", "r_leave", "s")

    def __init__(self, s: int, f_lo: int, f_td: int, kind: str) -> None:
        self.s, self.f_lo, self.f_td, self.kind = s, f_lo, f_td, kind
        n_sw = f_td - f_lo - 1
        self.K_leave = min(4, n_sw // 2)
        self.K_app = min(4, n_sw - self.K_leave)
        self.fa = f_td - self.K_app
        self.r_leave: FloatArray = np.zeros(3)
        self.plant: FloatArray | None = None
        self.dz = 0.0


class SeqGen:
    """The state of one sequence: body, key-framed channels, the root/contact simulation, FK."""

    keylog: list[dict[str, Any]] | None = None  # set to a list to record every key pose
    clamplog: list[tuple[int, int, float, str, float]] | None = None  # set to record floor clamps

    def __init__(self, seed: int, idx: int, duration: float = 60.0, fps: float = 30.0) -> None:
        self.seed, self.idx = seed, idx
        self.rng = R = np.random.default_rng([seed, idx, 0])
        self.fps = fps
        self.T = T = round(duration * fps)
        H = height_for(seed, idx, R)
        self.B = B = sample_body(R, H)
        # driven (key-framed) leg angles and additive layers
        self.drv = np.zeros((T, 2, 4))
        self.bump = np.zeros((T, 2, 2))
        self.psi = np.zeros(T)
        self.lst = np.zeros(T)
        self.tilt = np.zeros(T)
        self.beta = np.full(T, 0.5)
        self.heel = np.zeros((T, 2))
        self.gstate = np.zeros((T, 2), np.int8)
        self.swing_idx = np.full((T, 2), -1, int)
        self.swings: list[Swing] = []
        self.lo_map: dict[tuple[int, int], Swing] = {}
        # postural sway (pelvis over the feet), parallelogram angles applied to both legs
        self.sway_al = smooth_noise(R, T, fps, R.uniform(0.004, 0.010) / (B.L1 + B.L2), 0.25)
        self.sway_th = smooth_noise(R, T, fps, R.uniform(0.004, 0.010) / (B.L1 + B.L2), 0.2)
        self.sway_w = np.ones(T)  # postural sway is faded out while stepping / turning
        # simulated results
        self.pel = np.zeros((T, 3))
        self.hip = np.zeros((T, 2, 3))
        self.knee = np.zeros((T, 2, 3))
        self.ank = np.zeros((T, 2, 3))
        self.ang = np.zeros((T, 2, 4))
        self.corr = np.zeros((T, 2))  # closed-chain correction (deg, max |d angle|)
        self.corr_m = np.zeros((T, 2))  # same, as ankle displacement (m)
        self.lower = np.zeros(T)  # pelvis lowering needed to reach both plants (m)
        self.floor_clamp = 0
        # upper body layers
        self.spine = np.zeros((T, 2, 3))
        self.neck = np.zeros((T, 3))
        self.arm_ovr = np.zeros((T, 2, 5))
        self.arm_w = np.zeros((T, 2))
        self.armswing = np.zeros(T)
        self.carr_keys: list[tuple[int, FloatArray]] = []
        self.labels = np.array(["still"] * T, dtype="<U7")
        self.tags = np.array([""] * T, dtype="<U20")
        self.events: list[dict[str, Any]] = []
        self.bouts: list[dict[str, Any]] = []
        # initial stance: room centre, random facing
        psi0 = R.uniform(-math.pi, math.pi)
        C0 = R.normal(0.0, 0.03, 2)
        F, Y = self.home(C0, psi0)
        self.plant = np.array([[F[0][0], F[0][1], B.ankle_h], [F[1][0], F[1][1], B.ankle_h]])
        self.foot_yaw = np.array(Y, float)
        intent = Intent(self.plant, self.foot_yaw, psi0)
        self.init_vals: dict[TrackKey, float] = {}
        ang, p = self.solve_pose(
            C0, psi0, 0.0, {0: intent.F[0], 1: intent.F[1]}, self.rhos(intent, psi0), [0, 1], 0, B.knee0
        )
        for s in (0, 1):
            th, al, ka = ang[s]
            self.init_vals[("th", s)] = th
            self.init_vals[("al", s)] = al
            self.init_vals[("rh", s)] = self.rhos(intent, psi0)[s]
            self.init_vals[("ka", s)] = ka
            self.init_vals[("heel", s)] = 0.0
        self.init_vals["psi"] = psi0
        self.init_vals["lst"] = 0.0
        self.init_vals["tilt"] = 0.0
        self.init_vals["beta"] = 0.5
        self.init_pel = p
        self.carriage = self.sample_carriage()
        self.carr_keys.append((0, self.carriage.copy()))

    # ------------------------------------------------------------------ small helpers
    def sec(self, t: float) -> int:
        return round(t * self.fps)

    def U(self, a: float, b: float) -> float:
        return float(self.rng.uniform(a, b))

    def home(self, Cc: FloatArray, psi: float) -> tuple[list[FloatArray], list[float]]:
        B = self.B
        ex = np.array([math.cos(psi), math.sin(psi)])
        h = B.half_stance
        return [Cc - h * ex, Cc + h * ex], [psi + B.toe_out[0], psi - B.toe_out[1]]

    @staticmethod
    def rhos(intent: Intent, psi: float) -> list[float]:
        return [wrap(intent.Y[0] - psi), wrap(psi - intent.Y[1])]

    def hip_off(self, psi: float, lst: float) -> tuple[FloatArray, FloatArray]:
        hw = self.B.hw
        cps, sps = math.cos(psi), math.sin(psi)
        cl, sl = math.cos(lst), math.sin(lst)
        return (
            np.array([-hw * cl * cps, -hw * cl * sps, hw * sl]),
            np.array([hw * cl * cps, hw * cl * sps, -hw * sl]),
        )

    def heel_off(self, yaw: float, h: float) -> FloatArray:
        """Ankle displacement when the heel is raised by angle h about the ball of the foot."""
        B = self.B
        r, a = B.ball_r, B.ball_a
        fwd = -r * math.cos(a + h) + r * math.cos(a)
        up = r * math.sin(a + h) - r * math.sin(a)
        return np.array([-math.sin(yaw) * fwd, math.cos(yaw) * fwd, up])

    def Dmax(self) -> float:
        return leg_len(KA_MIN, self.B.L1, self.B.L2)

    # ------------------------------------------------------------------ pose solver
    def solve_pose(
        self,
        C: FloatArray,
        psi: float,
        lst: float,
        targets: dict[int, FloatArray],
        rh: Sequence[float],
        grounded: Sequence[int],
        primary: int,
        ka_p: float,
    ) -> tuple[dict[int, Vec3], FloatArray]:
        """Leg angles of the grounded legs for a key pose in which the pelvis centre is at C
        (xy) and the primary (weight-bearing) leg has knee flexion ka_p.  If the second grounded
        foot could not be reached with that pelvis, the pelvis is first moved towards the point
        between the feet (a person cannot hang over one foot of a wide stance with a straight
        leg) and only then lowered (both knees bend)."""
        B = self.B
        hoff = self.hip_off(psi, lst)
        b = primary
        Dm = leg_len(KA_MIN + 2.0 * D2R, B.L1, B.L2)
        D = leg_len(ka_p, B.L1, B.L2)

        def place(Cxy: FloatArray) -> tuple[FloatArray, float]:
            t = targets[b]
            vx = t[0] - Cxy[0] - hoff[b][0]
            vy = t[1] - Cxy[1] - hoff[b][1]
            r2 = vx * vx + vy * vy
            if r2 > 0.9 * D * D:
                k = math.sqrt(0.9 * D * D / r2)
                vx, vy, r2 = vx * k, vy * k, 0.9 * D * D
            pz = t[2] + math.sqrt(D * D - r2) - hoff[b][2]
            p = np.array([t[0] - vx - hoff[b][0], t[1] - vy - hoff[b][1], pz])
            need = 0.0
            for s in grounded:
                if s != b:
                    v = targets[s] - p - hoff[s]
                    if np.linalg.norm(v) > Dm:
                        hr2 = v[0] ** 2 + v[1] ** 2
                        need = -math.sqrt(max(Dm * Dm - hr2, 1e-6)) - v[2]
            return p, need

        C = np.asarray(C, float)[:2]
        p, need = place(C)
        if need > 0 and len(grounded) == 2:
            Cb = 0.5 * (targets[0][:2] + targets[1][:2])
            pb, nb = place(Cb)
            if nb > 0:
                p, need = pb, nb
            else:
                lo, hi = 0.0, 1.0
                for _ in range(12):
                    m = 0.5 * (lo + hi)
                    if place(C + m * (Cb - C))[1] > 0:
                        lo = m
                    else:
                        hi = m
                p, need = place(C + hi * (Cb - C))
        if need > 0:
            p[2] -= need
        ang: dict[int, Vec3] = {}
        cps, sps = math.cos(-psi), math.sin(-psi)
        for s in grounded:
            v = targets[s] - p - hoff[s]
            vx, vy = cps * v[0] - sps * v[1], sps * v[0] + cps * v[1]
            ang[s] = leg_angles_for(s, vx, vy, v[2], rh[s], B.L1, B.L2)
        return ang, p

    # ------------------------------------------------------------------ event scaffolding
    def prev(self, f0: int, name: TrackKey) -> float:
        if f0 == 0:
            return self.init_vals[name]
        if isinstance(name, tuple):
            nm, s = name
            if nm == "heel":
                return self.heel[f0 - 1, s]
            return self.drv[f0 - 1, s, LEG_CH.index(nm)]
        return {"psi": self.psi, "lst": self.lst, "tilt": self.tilt, "beta": self.beta}[name][f0 - 1]

    def begin(self, f0: int) -> tuple[Tracks, Intent]:
        tr: Tracks = {}
        for s in (0, 1):
            for nm in (*LEG_CH, "heel"):
                tr[(nm, s)] = Track(f0, self.prev(f0, (nm, s)))
        for nm in ("psi", "lst", "tilt", "beta"):
            tr[nm] = Track(f0, self.prev(f0, nm))
        psi = self.prev(f0, "psi")
        intent = Intent(self.plant.copy(), self.foot_yaw.copy(), psi)
        intent.last_f = f0 - 1
        intent.last_p = (self.pel[f0 - 1, :2] if f0 > 0 else self.init_pel[:2]).copy()
        intent.last_both = f0 == 0 or bool(np.all(self.gstate[f0 - 1] != SWING))
        intent.last_beta = self.prev(f0, "beta")
        intent.last_lst = self.prev(f0, "lst")
        intent.last_heel = (self.prev(f0, ("heel", 0)), self.prev(f0, ("heel", 1)))
        return tr, intent

    def end(self, tr: Tracks, f0: int, f1: int, still_sway: bool = True) -> int:
        assert f1 <= self.T, (f0, f1, self.T)
        if not still_sway:
            n = f1 - f0
            k = min(8, n // 2)
            env = np.zeros(n)
            env[:k] = 1.0 - (np.arange(k) + 1) / (k + 1)
            env[n - k :] = (np.arange(k) + 1) / (k + 1)
            self.sway_w[f0:f1] = env
        for t in tr.values():
            lf = t.last_frame()
            v = t.get(lf)
            assert lf <= f1 - 1, (lf, f1)
            if lf < f1 - 1:
                t.key(f1 - 1, v)
                if lf < f1 - 2:
                    t.key(f1 - 2, v)
        for s in (0, 1):
            for j, nm in enumerate(LEG_CH):
                self.drv[f0:f1, s, j] = tr[(nm, s)].eval(f0, f1)
            self.heel[f0:f1, s] = np.maximum(tr[("heel", s)].eval(f0, f1), 0.0)
        self.psi[f0:f1] = tr["psi"].eval(f0, f1)
        self.lst[f0:f1] = tr["lst"].eval(f0, f1)
        self.tilt[f0:f1] = tr["tilt"].eval(f0, f1)
        self.beta[f0:f1] = np.clip(tr["beta"].eval(f0, f1), 0.0, 1.0)
        for s in (0, 1):
            hs = (self.heel[f0:f1, s] > 0.5 * D2R) & (self.gstate[f0:f1, s] != SWING)
            self.gstate[f0:f1, s][hs] = HEEL
        self.simulate(f0, f1)
        return f1

    def pose_geom(
        self,
        intent: Intent,
        C: FloatArray,
        grounded: Sequence[int],
        primary: int,
        ka_p: float,
        lst: float,
        heel: Sequence[float],
        psi: float,
    ) -> tuple[dict[int, Vec3], FloatArray, list[float]]:
        if len(grounded) == 2:
            C = self.reachable_C(C, intent, psi, lst)
        rh = self.rhos(intent, psi)
        targets: dict[int, FloatArray] = {}
        for s in grounded:
            t = intent.F[s].copy()
            if heel[s] > 0:
                t = t + self.heel_off(intent.Y[s], heel[s])
            targets[s] = t
        ang, p = self.solve_pose(C, psi, lst, targets, rh, grounded, primary, ka_p)
        return ang, p, rh

    def pose(
        self,
        tr: Tracks,
        f: int,
        intent: Intent,
        C: FloatArray,
        grounded: Sequence[int],
        primary: int,
        ka_p: float | None = None,
        beta: float | None = None,
        lst: float = 0.0,
        heel: Sequence[float] = (0.0, 0.0),
        psi: float | None = None,
        breakdown: bool = True,
        record: bool = True,
        vmax: float | None = V_SHIFT,
    ) -> int:
        """Key pose at (or, if the pelvis would have to move faster than vmax on average, after)
        frame f: pelvis centre over C, given weight-bearing (primary) leg and its knee flexion.
        Between two double-support keys that are far apart a breakdown key (half-way pelvis,
        knee, list, heel) is inserted, as an animator would.  Returns the key frame used."""
        B = self.B
        psi = intent.psi if psi is None else psi
        ka_p = B.knee0 if ka_p is None else ka_p
        if beta is None:
            beta = 1.0 if primary == 1 else 0.0
        ang, p, rh = self.pose_geom(intent, C, grounded, primary, ka_p, lst, heel, psi)
        if record and vmax is not None and intent.last_f > -10:
            dist = float(np.linalg.norm(p[:2] - intent.last_p))
            f = max(f, intent.last_f + math.ceil(dist / vmax * self.fps))
        if (
            breakdown
            and len(grounded) == 2
            and intent.last_both
            and f - intent.last_f >= 6
            and abs(psi - intent.last_psi) < 1e-9
        ):
            fm = (intent.last_f + f) // 2
            kp = tr[("ka", primary)].keys.get(intent.last_f, ka_p)
            hm = tuple(0.5 * (a + b) for a, b in zip(intent.last_heel, heel, strict=True))
            self.pose(
                tr,
                fm,
                intent,
                0.5 * (p[:2] + intent.last_p),
                grounded,
                primary,
                ka_p=0.5 * (kp + ka_p),
                beta=0.5 * (beta + intent.last_beta),
                lst=0.5 * (lst + intent.last_lst),
                heel=hm,
                psi=psi,
                breakdown=False,
                record=False,
            )
        if self.keylog is not None:
            self.keylog.append(
                dict(
                    f=f,
                    C=np.array(C),
                    primary=primary,
                    ka_p=ka_p,
                    p=p,
                    F=intent.F.copy(),
                    ang=ang,
                    grounded=list(grounded),
                )
            )
        for s in grounded:
            th, al, ka = ang[s]
            tr[("th", s)].key(f, th)
            tr[("al", s)].key(f, al)
            tr[("rh", s)].key(f, rh[s])
            tr[("ka", s)].key(f, ka)
            tr[("heel", s)].key(f, heel[s])
        tr["beta"].key(f, beta)
        tr["lst"].key(f, lst)
        if record:
            intent.last_f, intent.last_p, intent.last_both = f, np.array(p[:2], float), len(grounded) == 2
            intent.last_beta, intent.last_lst, intent.last_heel, intent.last_psi = beta, lst, tuple(heel), psi
        return f

    def reachable_C(self, C: FloatArray, intent: Intent, psi: float, lst: float) -> FloatArray:
        """Keep both feet within ~23 deg of leg inclination: a person with a wide stance keeps
        the pelvis between the feet instead of dropping far down over one of them."""
        hoff = self.hip_off(psi, lst)
        rmax = 0.4 * (self.B.L1 + self.B.L2)
        C = np.array(C, float)[:2]
        for _ in range(3):
            ex = []
            for s in (0, 1):
                d = intent.F[s, :2] - (C + hoff[s][:2])
                n = float(np.linalg.norm(d))
                ex.append((n - rmax, d / max(n, 1e-9)))
            (e0, u0), (e1, u1) = ex
            if e0 <= 1e-4 and e1 <= 1e-4:
                break
            if e0 > 0 and e1 > 0:
                C = C + 0.5 * (e0 * u0 + e1 * u1)
                break
            e, u = (e0, u0) if e0 > 0 else (e1, u1)
            C = C + e * u
        return C

    def add_swing(
        self,
        tr: Tracks,
        s: int,
        f_lo: int,
        f_td: int,
        A_h: float,
        A_k: float,
        up_h: float = 0.45,
        up_k: float = 0.4,
        lat: tuple[float, float] = (0.2, 0.8),
        kind: str = "",
        min_clear: float = 0.03,
    ) -> Swing:
        """Swing of leg s between lift-off frame f_lo (last frame on the floor) and touch-down
        frame f_td.  The base angles are the key poses at f_lo / f_td; the lift is an analytic
        hip-flexion and knee-flexion bump; abduction / rotation change in the middle."""
        assert f_td - f_lo >= 3, (f_lo, f_td)
        n = f_td - f_lo
        fr = np.arange(f_lo + 1, f_td)
        u = (fr - f_lo) / n

        def bump(u: FloatArray, up: float, q: float) -> FloatArray:
            g = math.log(0.5) / math.log(up)
            return np.sin(math.pi * u**g) ** q

        # make sure the foot clearly leaves the floor (min_clear of ankle rise, ignoring the pelvis)
        B = self.B
        th0, th1 = tr[("th", s)].get(f_lo), tr[("th", s)].get(f_td)
        ka0, ka1 = tr[("ka", s)].get(f_lo), tr[("ka", s)].get(f_td)
        th_b, ka_b = th0 + (th1 - th0) * u, ka0 + (ka1 - ka0) * u

        def vert(th: FloatArray, ka: FloatArray) -> FloatArray:
            return B.L1 * np.cos(th) + B.L2 * np.cos(th - ka)

        for _ in range(30):
            rise = vert(th_b, ka_b) - vert(th_b + A_h * bump(u, up_h, 1.4), ka_b + A_k * bump(u, up_k, 1.25))
            if rise.max() >= min_clear:
                break
            A_k += 2.0 * D2R
        self.bump[fr, s, 0] = A_h * bump(u, up_h, 1.4)
        self.bump[fr, s, 1] = A_k * bump(u, up_k, 1.25)
        self.gstate[fr, s] = SWING
        for nm in ("al", "rh"):
            t = tr[(nm, s)]
            v0, v1 = t.get(f_lo), t.get(f_td)
            fa = f_lo + max(1, round(lat[0] * n))
            fb = f_td - max(1, round((1 - lat[1]) * n))
            if fb > fa:
                t.key(fa, v0)
                t.key(fb, v1)
        sw = Swing(s, f_lo, f_td, kind)
        self.swing_idx[fr, s] = len(self.swings)
        self.lo_map[(s, f_lo)] = sw
        self.swings.append(sw)
        return sw

    # ------------------------------------------------------------------ simulation
    def composed(self, f: int, s: int) -> tuple[float, float, float, float]:
        th, al, rh, ka = self.drv[f, s]
        th = th + self.bump[f, s, 0] - self.sway_th[f] * self.sway_w[f]
        sa = self.sway_al[f] * self.sway_w[f]
        al = al + (sa if s == 0 else -sa)
        ka = ka + self.bump[f, s, 1]
        return th, al, rh, ka

    def legvec_world(
        self, f: int, s: int, ang: Sequence[float] | None = None
    ) -> tuple[FloatArray, FloatArray]:
        B = self.B
        if ang is None:
            ang = self.composed(f, s)
        th, al, rh, ka = ang
        kv, av = leg_fk(s, th, al, rh, ka, B.L1, B.L2)
        c, sn = math.cos(self.psi[f]), math.sin(self.psi[f])

        def rot(v: Vec3) -> FloatArray:
            return np.array([c * v[0] - sn * v[1], sn * v[0] + c * v[1], v[2]])

        return rot(kv), rot(av)

    def ground_target(self, f: int, s: int) -> FloatArray:
        t = self.plant[s].copy()
        if self.gstate[f, s] == HEEL:
            t = t + self.heel_off(self.foot_yaw[s], self.heel[f, s])
        return t

    def simulate(self, f0: int, f1: int) -> None:
        """Place the root and the grounded feet frame by frame (see the module docstring)."""
        B = self.B
        Dm = self.Dmax() * (1 - 1e-7)
        for f in range(f0, f1):
            psi = self.psi[f]
            hoff = self.hip_off(psi, self.lst[f])
            # touch-down: plant the foot where the swing prediction put it
            for s in (0, 1):
                if f > 0 and self.gstate[f, s] != SWING and self.gstate[f - 1, s] == SWING:
                    sw = self.swings[self.swing_idx[f - 1, s]]
                    self.plant[s] = sw.plant
                    rh = self.drv[f, s, 2]
                    self.foot_yaw[s] = psi + rh if s == 0 else psi - rh
                if self.gstate[f, s] == SWING:
                    sw = self.swings[self.swing_idx[f, s]]
                    if f == sw.fa:
                        self.predict_landing(sw)
            drv = [self.composed(f, s) for s in (0, 1)]
            lv = [self.legvec_world(f, s, drv[s])[1] for s in (0, 1)]
            grounded = [s for s in (0, 1) if self.gstate[f, s] != SWING]
            assert grounded, f"no grounded foot at frame {f}"
            tgt = {s: self.ground_target(f, s) for s in grounded}
            cand = {s: tgt[s] - lv[s] - hoff[s] for s in grounded}
            if len(grounded) == 2:
                b = self.beta[f]
                p = (1 - b) * cand[0] + b * cand[1]
            else:
                p = cand[grounded[0]].copy()
            dz = 0.0
            for s in grounded:
                v = tgt[s] - p - hoff[s]
                if np.linalg.norm(v) > Dm:
                    hr2 = v[0] ** 2 + v[1] ** 2
                    dz = max(dz, -math.sqrt(max(Dm * Dm - hr2, 1e-6)) - v[2])
            p[2] -= dz
            self.lower[f] = dz
            # swing legs: fade-out of the stance correction after lift-off, fade-in of the
            # vertical landing correction, and the floor
            for s in (0, 1):
                if s in tgt:
                    continue
                sw = self.swings[self.swing_idx[f, s]]
                off = np.zeros(3)
                j = f - sw.f_lo
                if 1 <= j <= sw.K_leave:
                    off += sw.r_leave * (1.0 - smoothstep(j / (sw.K_leave + 1.0)))
                if f >= sw.fa:
                    off[2] += sw.dz * smoothstep((f - sw.fa + 1.0) / (sw.K_app + 1.0))
                a = p + hoff[s] + lv[s] + off
                if a[2] < B.ankle_h:
                    a[2] = B.ankle_h
                    self.floor_clamp += 1
                    if self.clamplog is not None:
                        self.clamplog.append(
                            (f, s, (f - sw.f_lo) / (sw.f_td - sw.f_lo), sw.kind, a[2] - B.ankle_h)
                        )
                    tgt[s] = a
                elif np.any(off != 0):
                    tgt[s] = a
            fin = [list(drv[0]), list(drv[1])]
            c, sn = math.cos(-psi), math.sin(-psi)
            for s, t in tgt.items():
                v = t - p - hoff[s]
                vx, vy = c * v[0] - sn * v[1], sn * v[0] + c * v[1]
                th, al, ka = leg_angles_for(s, vx, vy, v[2], drv[s][2], B.L1, B.L2, KA_MIN)
                self.corr[f, s] = (
                    max(abs(wrap(th - drv[s][0])), abs(al - drv[s][1]), abs(ka - drv[s][3])) / D2R
                )
                fin[s] = [th, al, drv[s][2], ka]
            self.pel[f] = p
            for s in (0, 1):
                kv, av = self.legvec_world(f, s, fin[s])
                self.hip[f, s] = p + hoff[s]
                self.knee[f, s] = p + hoff[s] + kv
                self.ank[f, s] = p + hoff[s] + av
                self.ang[f, s] = fin[s]
                if s in grounded:
                    self.corr_m[f, s] = np.linalg.norm(self.ank[f, s] - (p + hoff[s] + lv[s]))
                if (s, f) in self.lo_map:
                    self.lo_map[(s, f)].r_leave = self.ank[f, s] - (p + hoff[s] + lv[s])

    def predict_landing(self, sw: Swing) -> None:
        """Set the plant point of a swing from where forward kinematics puts the foot at touch-down."""
        s, o, f = sw.s, 1 - sw.s, sw.f_td
        assert self.gstate[f, o] != SWING and self.gstate[sw.fa, o] != SWING
        hoff = self.hip_off(self.psi[f], self.lst[f])
        t = self.plant[o].copy()
        if self.gstate[f, o] == HEEL:
            t = t + self.heel_off(self.foot_yaw[o], self.heel[f, o])
        p = t - self.legvec_world(f, o)[1] - hoff[o]
        a = p + hoff[s] + self.legvec_world(f, s)[1]
        sw.plant = np.array([a[0], a[1], self.B.ankle_h])
        sw.dz = self.B.ankle_h - a[2]

    # ------------------------------------------------------------------ arms: carriage
    def sample_carriage(self, mode: str | None = None) -> FloatArray:
        R = self.rng
        if mode is None:
            r = R.random()
            p = self.B.p_controllers
            mode = "controllers" if r < p * 0.85 else ("mixed" if r < p else "relaxed")
        pose = np.zeros((2, 5))
        for s in (0, 1):
            m = mode
            if mode == "mixed":
                m = "controllers" if s == self.B.handed else "relaxed"
            if m == "relaxed":
                pose[s] = [0, R.uniform(4, 11), R.uniform(-3, 8), R.uniform(-12, 5), R.uniform(8, 25)]
            else:
                pose[s] = [
                    R.uniform(-5, 5),
                    R.uniform(6, 15),
                    R.uniform(12, 35),
                    R.uniform(-40, -15),
                    R.uniform(65, 100),
                ]
        self.carr_mode = mode
        return pose * D2R

    def set_carriage(self, f: int, mode: str | None = None, n: int = 12) -> None:
        new = self.sample_carriage(mode)
        self.carr_keys.append((f, self.carriage.copy()))
        self.carr_keys.append((f + n, new))
        self.carriage = new

    def gesture_arm(
        self,
        side: int,
        fa: int,
        n_up: int,
        n_hold: int,
        n_down: int,
        pose: ArrayLike,
        osc: tuple[int, float, float] | None = None,
    ) -> None:
        env = envelope(n_up, n_hold, n_down)
        n = len(env)
        fb = min(fa + n, self.T)
        env = env[: fb - fa]
        fr = np.arange(fa, fb)
        val = np.tile(np.asarray(pose, float), (len(fr), 1))
        if osc is not None:
            ch, amp, freq = osc
            t = np.arange(len(fr)) / self.fps
            oenv = envelope(n_up, n_hold, n_down)[: len(fr)] ** 2
            val[:, ch] += amp * np.sin(2 * math.pi * freq * t) * oenv
        self.arm_ovr[fr, side] = np.where(
            env[:, None] >= self.arm_w[fr, side][:, None], val, self.arm_ovr[fr, side]
        )
        self.arm_w[fr, side] = np.maximum(self.arm_w[fr, side], env)

    def add_upper(
        self,
        arr_fn: Callable[[slice, FloatArray], None],
        fa: int,
        keys: Iterable[tuple[float, float]],
        n: int,
    ) -> None:
        """Add a key-framed curve (zero at both ends) to an upper-body channel."""
        n = min(n, self.T - fa)
        if n <= 0:
            return
        ends = [(0, 0.0), *list(keys), (n - 1, 0.0)]
        arr_fn(slice(fa, fa + n), keycurve(n, [(min(max(k, 0), n - 1), v) for k, v in ends]))

    # ------------------------------------------------------------------ upper body + output
    def assemble(self) -> FloatArray:
        """The 17 COCO keypoints (T, 17, 3) in m after run(): upper-body FK on the simulated legs."""
        T, B, R, fps = self.T, self.B, self.rng, self.fps
        # arms: carriage key frames, arm swing coupled to the legs, gesture overrides
        ks = sorted(self.carr_keys, key=lambda k: k[0])
        arm = np.zeros((T, 2, 5))
        for s in (0, 1):
            for c in range(5):
                arm[:, s, c] = keycurve(T, [(f, p[s, c]) for f, p in ks])
        dth = self.ang[:, 1, 0] - self.ang[:, 0, 0]
        dth = np.concatenate([np.full(2, dth[0]), dth[:-2]])  # arms lag the legs ~65 ms
        sw = gaussian_filter1d(self.armswing, 3) * dth
        arm[:, 0, 2] += sw
        arm[:, 1, 2] -= sw
        arm[:, 0, 4] += 0.3 * np.maximum(sw, 0)
        arm[:, 1, 4] += 0.3 * np.maximum(-sw, 0)
        for s in (0, 1):
            for c, sd in ((1, 1.2), (2, 1.5), (3, 2.0), (4, 2.0)):
                arm[:, s, c] += smooth_noise(R, T, fps, sd * D2R, 0.3)
        w = self.arm_w[..., None]
        arm = (1 - w) * arm + w * self.arm_ovr
        trunk_d = self.tilt + self.spine[:, 0, 0] + self.spine[:, 1, 0]
        arm[:, :, 2] += (1 - self.arm_w) * 0.85 * trunk_d[:, None]  # relaxed arms hang
        # spine / neck
        breath = 0.6 * D2R * np.sin(2 * math.pi * self.U(0.2, 0.33) * np.arange(T) / fps + self.U(0, 6.3))
        ex = np.stack([np.cos(self.psi), np.sin(self.psi)], 1)
        d_lat = np.sum((self.pel[:, :2] - self.ank[:, :, :2].mean(1)) * ex, 1)
        lum_f = B.lumbar0 + self.spine[:, 0, 0] + smooth_noise(R, T, fps, 0.5 * D2R, 0.2)
        tho_f = B.thoracic0 + self.spine[:, 1, 0] + breath
        lum_l = self.spine[:, 0, 1] - 0.8 * self.lst
        tho_l = self.spine[:, 1, 1] + 25 * D2R * d_lat + smooth_noise(R, T, fps, 0.5 * D2R, 0.2)
        tw = -0.15 * sw
        lum_t = self.spine[:, 0, 2] + 0.4 * tw
        tho_t = self.spine[:, 1, 2] + 0.6 * tw + smooth_noise(R, T, fps, 1.0 * D2R, 0.2)
        nyaw = self.neck[:, 0] - 0.8 * tw + smooth_noise(R, T, fps, 2.0 * D2R, 0.3)
        npitch = (
            B.neck_pitch0
            - 0.8 * (B.tilt0 + B.lumbar0 + B.thoracic0)
            + self.neck[:, 1]
            + smooth_noise(R, T, fps, 1.5 * D2R, 0.3)
        )
        nroll = B.head_roll0 + self.neck[:, 2] + smooth_noise(R, T, fps, 1.0 * D2R, 0.2)
        # forward kinematics of the upper body
        Rp = rot_z(self.psi) @ rot_y(self.lst) @ rot_x(-(B.tilt0 + self.tilt))
        R1 = Rp @ rot_x(-lum_f) @ rot_y(lum_l) @ rot_z(lum_t)
        mid = self.pel + R1[:, :, 2] * B.s1
        R2 = R1 @ rot_x(-tho_f) @ rot_y(tho_l) @ rot_z(tho_t)
        nb = mid + R2[:, :, 2] * B.s2
        shL = nb + mv(R2, [-B.sw, B.sh_dy, B.sh_dz])
        shR = nb + mv(R2, [B.sw, B.sh_dy, B.sh_dz])
        Rn = R2 @ rot_z(0.4 * nyaw) @ rot_x(-0.4 * npitch) @ rot_y(0.4 * nroll)
        piv = nb + mv(Rn, [0.0, B.neck_dy, B.neck])
        Rh = R2 @ rot_z(nyaw) @ rot_x(-npitch) @ rot_y(nroll)
        face = [piv + mv(Rh, B.head[i]) for i in range(5)]
        wr, el = [], []
        for s, sh in ((0, shL), (1, shR)):
            sg = 1.0 if s == 0 else -1.0
            h, ab, fl, ro, eb = [arm[:, s, c] for c in range(5)]
            Ru = R2 @ rot_z(sg * h) @ rot_y(sg * ab) @ rot_x(fl) @ rot_z(sg * ro)
            e = sh + Ru[:, :, 2] * (-B.Lu)
            Rf = Ru @ rot_x(eb)
            el.append(e)
            wr.append(e + Rf[:, :, 2] * (-B.Lf))
        J = np.stack(
            [
                *face,
                shL,
                shR,
                el[0],
                el[1],
                wr[0],
                wr[1],
                self.hip[:, 0],
                self.hip[:, 1],
                self.knee[:, 0],
                self.knee[:, 1],
                self.ank[:, 0],
                self.ank[:, 1],
            ],
            1,
        )
        self.arm_final = arm
        return J
