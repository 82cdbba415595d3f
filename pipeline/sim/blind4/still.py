"""Still behaviours of the planner: turns, weight shifts, sways, gestures, looks, stretches, bows."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.blind4.body import Body
from pipeline.sim.blind4.mathutil import FPS, smoothstep
from pipeline.sim.blind4.records import LEFT, RIGHT, Bout, Event, Swing
from pipeline.sim.blind4.records import sec_frames as _sec


class StillBehaviours:
    """Mixin for :class:`pipeline.sim.blind4.plan.Planner` holding the label-``still`` behaviours."""

    rng: np.random.Generator
    body: Body
    n: int
    events: list[Event]
    swings: list[Swing]
    pos: NDArray[np.float64]
    yaw: NDArray[np.float64]
    heading: float
    tags: NDArray[np.str_]
    w_base: NDArray[np.float64]
    zmp_ap: NDArray[np.float64]

    # provided by the planner
    def _home(
        self, foot: int, center: NDArray[np.float64] | None = None, heading: float | None = None
    ) -> NDArray[np.float64]:
        raise NotImplementedError

    def _home_yaw(self, foot: int, heading: float | None = None) -> float:
        raise NotImplementedError

    def _resync(self) -> None:
        raise NotImplementedError

    def _add_swing(
        self,
        foot: int,
        lo: int,
        td: int,
        p1: NDArray[np.float64],
        yaw1: float,
        apex: float,
        kind: str,
        **extra: float,
    ) -> Swing:
        raise NotImplementedError

    def turn(self, t: int, avail: int) -> int | None:
        """Turn on the spot with 2-6 pivot steps (label still, tag ``turn``); returns the end frame."""
        rng = self.rng
        n = int(rng.integers(2, 7))
        period = rng.uniform(0.45, 0.9)
        need = round((n * period + 0.6) * FPS)
        while need > avail and n > 2:
            n -= 1
            need = round((n * period + 0.6) * FPS)
        if need > avail:
            return None
        total = math.radians(rng.uniform(45.0, 180.0)) * (1 if rng.random() < 0.5 else -1)
        first = LEFT if total > 0 else RIGHT
        th0 = self.heading
        lo = t + round(0.3 * FPS)
        start = lo
        for j in range(1, n + 1):
            foot = first if j % 2 == 1 else 1 - first
            th = th0 + total * min(j / (n - 1), 1.0)
            ns = round(period * rng.uniform(0.45, 0.65) * FPS)
            td = lo + max(ns, 5)
            p1 = self._home(foot, heading=th) + rng.normal(0.0, 0.01, size=2)
            self._add_swing(
                foot,
                lo,
                td,
                p1,
                self._home_yaw(foot, th) + rng.normal(0.0, 0.03),
                rng.uniform(0.015, 0.05),
                "turn",
                heel=rng.uniform(0.0, 0.01),
                heel_frames=int(rng.integers(0, 4)),
                land_frames=2,
                peak=rng.uniform(0.4, 0.6),
            )
            lo = td + max(2, round(period * FPS) - (td - lo))
        end = self.swings[-1].td
        self._resync()
        a, b = max(start - 3, t), min(end + 4, t + avail)
        self.tags[a:b] = "turn"
        self.events.append(Event("turn", start, end, {"angle": total}))
        return b

    def weight_shift(self, t: int, avail: int) -> int | None:
        """Shift the weight from foot to foot, sometimes unloading/lifting the free foot."""
        rng = self.rng
        n_shift = int(rng.integers(1, 4))
        side = int(rng.integers(2))
        while n_shift >= 1:
            segs = [(_sec(rng, 0.35, 0.7), _sec(rng, 0.5, 1.4)) for _ in range(n_shift)]
            back = _sec(rng, 0.35, 0.7)
            dur = sum(a + b for a, b in segs) + back
            if dur <= avail:
                break
            n_shift -= 1
        else:
            return None
        cur, f = 0.5, t
        for tr, hold in segs:
            target = 0.5 + (1 if side == LEFT else -1) * rng.uniform(0.25, 0.42)
            ramp = smoothstep(np.arange(tr) / tr)
            self.w_base[f : f + tr] = cur + (target - cur) * ramp
            self.w_base[f + tr : f + tr + hold] = target
            if hold >= int(0.7 * FPS) and rng.random() < 0.35:
                free = RIGHT if side == LEFT else LEFT
                lo = f + tr + int(0.2 * FPS)
                td = min(lo + _sec(rng, 0.25, 0.5), f + tr + hold - 3)
                if td - lo >= 5:
                    self._add_swing(
                        free,
                        lo,
                        td,
                        self.pos[free] + rng.normal(0.0, 0.01, size=2),
                        self.yaw[free] + rng.normal(0.0, 0.03),
                        rng.uniform(0.01, 0.05),
                        "shift",
                        land_frames=2,
                        peak=0.5,
                    )
            cur, f = target, f + tr + hold
            side = 1 - side
        self.w_base[f : f + back] = cur + (0.5 - cur) * smoothstep(np.arange(back) / back)
        f += back
        self.tags[t:f] = "weight-shift"
        return f

    def sway(self, t: int, avail: int) -> int | None:
        """A short side-to-side / fore-aft body sway with the feet planted."""
        rng = self.rng
        dur = min(_sec(rng, 2.0, 4.0), avail)
        if dur < int(1.5 * FPS):
            return None
        tt = np.arange(dur) / FPS
        env = np.minimum(smoothstep(tt / 0.5), smoothstep((dur / FPS - tt) / 0.5))
        freq, ph = rng.uniform(0.3, 0.7), rng.uniform(0, 2 * math.pi)
        self.w_base[t : t + dur] = 0.5 + env * rng.uniform(0.15, 0.35) * np.sin(2 * math.pi * freq * tt + ph)
        self.zmp_ap[t : t + dur] = env * rng.uniform(0.0, 0.025) * np.sin(2 * math.pi * freq * 0.5 * tt)
        self.tags[t : t + dur] = "sway"
        return t + dur

    def upper_event(self, kind: str, t: int, avail: int) -> int | None:
        """Gesture, look-around, stretch, bow or idle pose change (feet planted)."""
        rng = self.rng
        ranges = {
            "gesture": (1.5, 3.2),
            "look-around": (1.5, 4.0),
            "stretch": (2.5, 5.0),
            "bow": (1.5, 3.0),
            "idle": (2.0, 5.0),
        }
        lo_s, hi_s = ranges[kind]
        dur = min(_sec(rng, lo_s, hi_s), avail)
        if dur < int(lo_s * FPS * 0.8):
            return None
        p: dict[str, float] = {}
        if kind == "gesture":
            p["type"] = float(rng.choice([0, 1, 2]))
            p["arm"] = float(RIGHT if rng.random() < 0.65 else LEFT)
            p["seed"] = float(rng.integers(1 << 30))
        elif kind == "look-around":
            s = 1 if rng.random() < 0.5 else -1
            p.update(
                yaw1=s * math.radians(rng.uniform(30, 70)),
                yaw2=-s * math.radians(rng.uniform(0, 60)) if rng.random() < 0.6 else 0.0,
                pitch=math.radians(rng.uniform(-15, 15)),
            )
        elif kind == "stretch":
            p.update(
                type=float(rng.choice([0, 1, 2])),
                roll=math.radians(rng.uniform(-15, 15)),
                seed=float(rng.integers(1 << 30)),
            )
        elif kind == "bow":
            p.update(pitch=math.radians(rng.uniform(15, 45)), head=math.radians(rng.uniform(0, 15)))
        else:
            p.update(type=float(rng.choice([0, 1, 2, 3])), arms=2.0)
        self.events.append(Event("pose" if kind == "idle" else kind, t, t + dur, p))
        self.tags[t : t + dur] = kind
        return t + dur

    def still(self, start: int, end: int) -> None:
        """Fill frames [start, end) with still behaviours."""
        rng = self.rng
        t = start + _sec(rng, 0.2, 0.7)
        stop = end - int(0.6 * FPS)
        turned = False
        kinds = ["weight-shift", "turn", "gesture", "look-around", "stretch", "bow", "sway", "idle", "plain"]
        probs = np.array([0.17, 0.17, 0.16, 0.13, 0.07, 0.07, 0.07, 0.1, 0.06])
        for _ in range(4):
            avail = stop - t
            if avail < int(1.2 * FPS):
                break
            kind = str(rng.choice(kinds, p=probs / probs.sum()))
            if kind == "turn" and turned:
                kind = "plain"
            if kind == "plain":
                res: int | None = t + min(_sec(rng, 0.5, 2.0), avail)
            elif kind == "turn":
                res = self.turn(t, avail)
                turned = turned or res is not None
            elif kind == "weight-shift":
                res = self.weight_shift(t, avail)
            elif kind == "sway":
                res = self.sway(t, avail)
            else:
                res = self.upper_event(kind, t, avail)
            if res is None:
                continue
            t = res + _sec(rng, 0.0, 0.8)

    def look_during(self, bout: Bout) -> None:
        """Occasional glance while stepping (does not change the tag)."""
        if self.rng.random() < 0.25 and bout.end - bout.start > 2 * FPS:
            a = int(self.rng.integers(bout.start, bout.end - int(1.5 * FPS)))
            s = 1 if self.rng.random() < 0.5 else -1
            self.events.append(
                Event(
                    "look-around",
                    a,
                    a + _sec(self.rng, 1.0, 1.5),
                    {"yaw1": s * math.radians(self.rng.uniform(20, 50)), "yaw2": 0.0, "pitch": 0.0},
                )
            )
