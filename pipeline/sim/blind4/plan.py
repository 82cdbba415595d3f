"""Behaviour script and footstep planner.

The planner alternates still stretches and stepping bouts over the sequence and, for
every bout or still behaviour that moves a foot, emits :class:`Swing` records (lift-off
frame, touch-down frame, start/end floor pose, apex height, heel/toe details).  It also
writes the frame labels and tags, a baseline weight-distribution signal for weight
shifts / sways, and :class:`Event` records that drive the upper body.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.blind4.body import Body
from pipeline.sim.blind4.mathutil import FPS, fwd_vec, right_vec
from pipeline.sim.blind4.records import LABELS, LEFT, MAX_GAP, RIGHT, Bout, Event, Plan, Swing
from pipeline.sim.blind4.records import sec_frames as _sec
from pipeline.sim.blind4.still import StillBehaviours

__all__ = ["LABELS", "LEFT", "MAX_GAP", "RIGHT", "Bout", "Event", "Plan", "Planner", "Swing", "make_plan"]


class Planner(StillBehaviours):
    """Stateful planner that tracks the feet and appends behaviours in time order."""

    def __init__(self, rng: np.random.Generator, body: Body, n_frames: int) -> None:
        self.rng = rng
        self.body = body
        self.n = n_frames
        r = 0.2 * math.sqrt(rng.uniform())
        a = rng.uniform(0.0, 2.0 * math.pi)
        self.center = np.array([r * math.cos(a), r * math.sin(a)])
        self.heading = float(rng.uniform(-math.pi, math.pi))
        self.pos = np.stack([self._home(LEFT), self._home(RIGHT)])
        self.yaw = np.array([self._home_yaw(LEFT), self._home_yaw(RIGHT)])
        self.init_pos = self.pos.copy()
        self.init_yaw = self.yaw.copy()
        self.last: list[Swing | None] = [None, None]
        self.swings: list[Swing] = []
        self.bouts: list[Bout] = []
        self.events: list[Event] = []
        self.labels = np.full(n_frames, "still", dtype="<U7")
        self.tags = np.full(n_frames, "", dtype="<U20")
        self.w_base = np.full(n_frames, 0.5)
        self.zmp_ap = np.zeros(n_frames)
        self.arm_swing = np.zeros(n_frames)
        self.arm_abduct = np.zeros(n_frames)

    # ------------------------------------------------------------------ geometry
    def _home(
        self, foot: int, center: NDArray[np.float64] | None = None, heading: float | None = None
    ) -> NDArray[np.float64]:
        c = self.center if center is None else center
        th = self.heading if heading is None else heading
        side = -1.0 if foot == LEFT else 1.0
        return c + side * self.body.stance_half * right_vec(th)

    def _home_yaw(self, foot: int, heading: float | None = None) -> float:
        th = self.heading if heading is None else heading
        return th + self.body.toe_out if foot == LEFT else th - self.body.toe_out

    def _resync(self) -> None:
        """Re-derive the stance centre and heading from the feet."""
        self.center = self.pos.mean(axis=0)
        self.heading = float(self.yaw.mean())

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
        prev = self.last[foot]
        sw = Swing(
            foot=foot,
            lo=lo,
            td=td,
            p0=self.pos[foot].copy(),
            p1=np.asarray(p1, dtype=np.float64),
            yaw0=float(self.yaw[foot]),
            yaw1=float(yaw1),
            apex=float(apex),
            kind=kind,
        )
        for k, v in extra.items():
            setattr(sw, k, int(v) if k.endswith("frames") else float(v))
        # keep heel-off / heel-down phases of consecutive swings of one foot apart
        if prev is not None:
            avail = lo - prev.td
            prev.land_frames = min(prev.land_frames, max(avail // 2 - 1, 0))
            sw.heel_frames = min(sw.heel_frames, max(avail - prev.land_frames - 2, 0))
        else:
            sw.heel_frames = min(sw.heel_frames, lo)
        if sw.heel_frames == 0:
            sw.heel = 0.0
        self.swings.append(sw)
        self.last[foot] = sw
        self.pos[foot] = sw.p1
        self.yaw[foot] = sw.yaw1
        return sw

    # ------------------------------------------------------------------ timing
    def _timeline(
        self,
        feet: list[int],
        start: int,
        cadence: float,
        swing_frac: float,
        jitter: float,
        hesitant: bool,
        n_slow: int,
        pause_prob: float,
        dur_asym: tuple[float, float],
        min_gap: int = 2,
    ) -> tuple[list[tuple[int, int]], list[tuple[int, int]]]:
        """Lift-off / touch-down frames for a list of stepping feet, plus inserted pauses."""
        rng = self.rng
        period = 1.0 / cadence
        t = start
        out: list[tuple[int, int]] = []
        pauses: list[tuple[int, int]] = []
        n = len(feet)
        for k, foot in enumerate(feet):
            mod = 1.0 + float(np.clip(rng.normal(0.0, jitter), -2.5 * jitter, 2.5 * jitter))
            if k == 0 and hesitant:
                mod *= rng.uniform(1.3, 1.8)
            if k >= n - n_slow:
                mod *= 1.0 + (k - (n - n_slow) + 1) * rng.uniform(0.08, 0.22)
            pk = period * mod
            s = float(np.clip(pk * swing_frac * dur_asym[foot] * rng.uniform(0.94, 1.06), 0.18, 1.1))
            ns = max(4, round(s * FPS))
            lo, td = t, t + ns
            gap = int(np.clip(round((pk - s) * FPS), min_gap, MAX_GAP))
            if k < n - 1 and rng.random() < pause_prob:
                extra = min(_sec(rng, 0.2, 1.0), MAX_GAP - gap)
                if extra >= 6:
                    pauses.append((td + gap // 2, td + gap // 2 + extra))
                    gap += extra
            out.append((lo, td))
            t = td + gap
        return out, pauses

    def _bout_common(
        self,
        label: str,
        tag: str,
        cadence: float,
        times: list[tuple[int, int]],
        pauses: list[tuple[int, int]],
        arm_mode: str,
    ) -> Bout:
        start, end = times[0][0], times[-1][1]
        self.labels[start : end + 1] = label
        self.tags[start : end + 1] = tag
        for a, b in pauses:
            self.tags[a:b] = "pause"
        bout = Bout(start=start, end=end, label=label, tag=tag, cadence=cadence, arm_mode=arm_mode)
        self.bouts.append(bout)
        if arm_mode in ("held", "hips"):
            kind = 3.0 if arm_mode == "held" else 0.0
            self.events.append(
                Event(
                    "pose",
                    max(start - _sec(self.rng, 0.3, 1.0), 0),
                    min(end + _sec(self.rng, 0.3, 1.0), self.n),
                    {"type": kind, "arms": 2.0},
                )
            )
        return bout

    def _fit_steps(
        self, make_feet: Callable[[int], list[int]], n: int, unit: int, start: int, hard_end: int, **kw: Any
    ) -> tuple[list[int], list[tuple[int, int]], list[tuple[int, int]]]:
        """Adjust the step count (in multiples of ``unit``) so the bout lasts >= 2 s and ends by
        ``hard_end``."""
        state = self.rng.bit_generator.state
        min_len = int(2.0 * FPS)
        shrinking = False
        while True:
            self.rng.bit_generator.state = state
            feet = make_feet(n)
            times, pauses = self._timeline(feet, start, **kw)
            too_long = times[-1][1] - times[0][0] >= int(10.0 * FPS)
            if (times[-1][1] > hard_end or too_long) and n > unit:
                n, shrinking = n - unit, True
                continue
            if times[-1][1] - times[0][0] < min_len and not shrinking and n < 200:
                n += unit
                continue
            return feet, times, pauses

    # ------------------------------------------------------------------ bouts
    def march(self, start: int, target_s: float, hard_end: int) -> Bout:
        """Marching in place: alternating knee lifts, feet land back near where they were."""
        rng = self.rng
        cadence = float(rng.uniform(0.6, 2.4))
        u = rng.random()
        apex_base = (
            rng.uniform(0.04, 0.10)
            if u < 0.35
            else (rng.uniform(0.10, 0.22) if u < 0.7 else rng.uniform(0.22, 0.35))
        )
        asym = rng.uniform(0.78, 1.22, size=2)
        dur_asym = (float(rng.uniform(0.9, 1.1)), float(rng.uniform(0.9, 1.1)))
        reach_k = rng.uniform(0.1, 0.7)
        first = int(rng.integers(2))
        travel = rng.uniform(0.0, 0.02) if (rng.random() < 0.5 and np.linalg.norm(self.center) < 0.3) else 0.0
        hesitant = rng.random() < 0.3
        n0 = max(3, round(target_s * cadence))
        feet, times, pauses = self._fit_steps(
            lambda n: [first if k % 2 == 0 else 1 - first for k in range(n)],
            n0,
            1,
            start,
            hard_end,
            cadence=cadence,
            swing_frac=float(rng.uniform(0.5, 0.8)),
            jitter=float(rng.uniform(0.05, 0.15)),
            hesitant=hesitant,
            n_slow=int(rng.integers(0, 3)) if rng.random() < 0.4 else 0,
            pause_prob=0.12 if rng.random() < 0.4 else 0.0,
            dur_asym=dur_asym,
        )
        fwd = fwd_vec(self.heading)
        for k, (foot, (lo, td)) in enumerate(zip(feet, times, strict=True)):
            s = (td - lo) / FPS
            apex = min(apex_base * asym[foot] * rng.uniform(0.85, 1.15), 0.03 + 0.6 * s)
            if k == 0 and hesitant:
                apex *= rng.uniform(0.4, 0.7)
            self.center = self.center + fwd * travel
            p1 = self._home(foot) + rng.normal(0.0, 0.008, size=2)
            yaw1 = self._home_yaw(foot) + rng.normal(0.0, 0.03)
            self._add_swing(
                foot,
                lo,
                td,
                p1,
                yaw1,
                apex,
                "march",
                reach=reach_k * apex,
                heel=rng.uniform(0.008, 0.02),
                heel_frames=int(rng.integers(3, 6)),
                land=rng.uniform(0.0, 0.012),
                land_frames=int(rng.integers(2, 5)),
                peak=rng.uniform(0.4, 0.55),
            )
        self._resync()
        arm_mode = str(rng.choice(["swing", "swing", "passive", "held", "hips"]))
        bout = self._bout_common("forward", "march", cadence, times, pauses, arm_mode)
        if arm_mode == "swing":
            amp = math.radians(rng.uniform(10.0, 35.0)) * min(1.0, 0.5 + apex_base / 0.2)
            self.arm_swing[bout.start : bout.end + 1] = amp
        return bout

    def side(self, direction: int, kind: str, start: int, target_s: float, hard_end: int) -> Bout:
        """Side stepping to the person's right (+1) or left (-1)."""
        rng = self.rng
        lead = RIGHT if direction > 0 else LEFT
        trail = 1 - lead
        rvec = right_vec(self.heading) * direction
        if kind == "shuffle":
            cadence, width = float(rng.uniform(1.2, 2.4)), float(rng.uniform(0.10, 0.25))
            apex_rng, sf = (0.01, 0.03), float(rng.uniform(0.45, 0.7))
        elif kind == "step-together":
            cadence, width = float(rng.uniform(0.6, 2.0)), float(rng.uniform(0.10, 0.40))
            apex_rng, sf = (0.03, 0.12), float(rng.uniform(0.5, 0.8))
        else:
            cadence, width = (
                float(rng.uniform(0.6, 2.0)),
                float(rng.uniform(0.10, min(0.45, 0.26 * self.body.height))),
            )
            apex_rng, sf = (0.03, 0.12), float(rng.uniform(0.5, 0.8))
        width = min(width, 0.45 - 0.2 * max(cadence - 1.0, 0.0))  # wide steps are slower
        travelling = kind == "step-together" or (kind == "shuffle" and rng.random() < 0.6)
        reps = max(1, round(target_s * cadence / 2.0))
        if travelling:
            # room along the stepping direction before leaving a 0.4 m disc around the origin
            cd = float(self.center @ rvec)
            room = -cd + math.sqrt(max(cd * cd - float(self.center @ self.center) + 0.4**2, 0.0))
            reps = max(reps, math.ceil(1.1 * cadence))
            reps = min(reps, int(room / 0.10))
            if reps >= 1:
                width = min(width, room / reps)
            if reps * 2.0 / cadence < 2.2:
                reps = max(1, round(target_s * cadence / 2.0))
                travelling = False
                if kind == "step-together":
                    kind = "side-step-out-back"
        tag = kind
        hesitant = rng.random() < 0.25
        dur_asym = (float(rng.uniform(0.9, 1.1)), float(rng.uniform(0.9, 1.1)))
        if travelling:
            make = lambda n: [lead if k % 2 == 0 else trail for k in range(n)]  # noqa: E731
        else:
            make = lambda n: [lead] * n  # noqa: E731
        feet, times, pauses = self._fit_steps(
            make,
            2 * reps,
            2,
            start,
            hard_end,
            cadence=cadence,
            swing_frac=sf,
            min_gap=round((0.12 + 0.6 * width) * FPS),
            jitter=float(rng.uniform(0.05, 0.15)),
            hesitant=hesitant,
            n_slow=int(rng.integers(0, 3)) if rng.random() < 0.4 else 0,
            pause_prob=0.12 if rng.random() < 0.4 else 0.0,
            dur_asym=dur_asym,
        )
        apex_f = rng.uniform(*apex_rng, size=2)
        low = kind == "shuffle"
        for k, (foot, (lo, td)) in enumerate(zip(feet, times, strict=True)):
            w = width * rng.uniform(0.9, 1.1)
            if travelling:
                if foot == lead:
                    p1 = self.pos[lead] + rvec * w + rng.normal(0.0, 0.008, size=2)
                else:
                    new_c = self.pos[lead] - rvec * self.body.stance_half * rng.uniform(0.85, 1.1)
                    p1 = new_c - rvec * self.body.stance_half + rng.normal(0.0, 0.008, size=2)
            else:
                home = self._home(lead)
                p1 = (home + rvec * w if k % 2 == 0 else home) + rng.normal(0.0, 0.008, size=2)
            yaw1 = self._home_yaw(foot) + rng.normal(0.0, 0.03)
            apex = apex_f[foot] * rng.uniform(0.85, 1.15)
            if k == 0 and hesitant:
                apex *= rng.uniform(0.5, 0.8)
            self._add_swing(
                foot,
                lo,
                td,
                p1,
                yaw1,
                apex,
                "shuffle" if low else "side",
                heel=0.0 if low else rng.uniform(0.0, 0.012),
                heel_frames=0 if low else int(rng.integers(2, 5)),
                land=0.0 if low else rng.uniform(0.0, 0.008),
                land_frames=int(rng.integers(2, 4)),
                peak=rng.uniform(0.4, 0.6),
            )
        self._resync()
        arm_mode = str(rng.choice(["passive", "passive", "held", "hips", "abduct"]))
        label = "right" if direction > 0 else "left"
        bout = self._bout_common(
            label, tag, cadence, times, pauses, arm_mode if arm_mode != "abduct" else "passive"
        )
        if arm_mode == "abduct":
            self.arm_abduct[bout.start : bout.end + 1] = math.radians(rng.uniform(15.0, 45.0))
        return bout

    def finish(self) -> Plan:
        """Freeze the planner into a :class:`Plan`."""
        self.swings.sort(key=lambda s: s.lo)
        return Plan(
            n_frames=self.n,
            init_pos=self.init_pos,
            init_yaw=self.init_yaw,
            swings=self.swings,
            bouts=self.bouts,
            events=self.events,
            labels=self.labels,
            tags=self.tags,
            w_base=self.w_base,
            zmp_ap=self.zmp_ap,
            arm_swing=self.arm_swing,
            arm_abduct=self.arm_abduct,
        )


def make_plan(rng: np.random.Generator, body: Body, n_frames: int) -> Plan:
    """Script a whole sequence: still stretches alternating with stepping bouts (~40-50 % stepping)."""
    pl = Planner(rng, body, n_frames)
    frac = float(rng.uniform(0.40, 0.47))
    order = list(rng.permutation(["forward", "left", "right"]))
    side_kinds = list(rng.permutation(["side-step-out-back", "step-together", "shuffle"]))
    cursor, step_frames, still_frames, first = 0, 0, 0, True
    min_bout, min_still = int(4.5 * FPS), int(1.5 * FPS)  # min_bout: room reserved for a bout
    while cursor < n_frames:
        rem = n_frames - cursor
        if rem < min_still + min_bout + min_still:
            pl.still(cursor, n_frames)
            break
        if first:
            dur = _sec(rng, 1.5, 4.0)
        else:
            want = (1.0 - frac) / frac * step_frames - still_frames
            dur = int(np.clip(want * rng.uniform(0.75, 1.25), min_still, 6.0 * FPS))
        dur = min(dur, rem - min_bout - min_still)
        pl.still(cursor, cursor + dur)
        still_frames += dur
        cursor += dur
        first = False
        if not order:
            prev = [b.label for b in pl.bouts[-2:]]
            choices = [d for d in ("forward", "left", "right") if prev.count(d) < 2]
            w = np.array([0.4 if d == "forward" else 0.3 for d in choices])
            order.append(str(rng.choice(choices, p=w / w.sum())))
        direction = order.pop(0)
        hard_end = n_frames - min_still - 1
        ahead = step_frames > frac * (step_frames + still_frames)
        target = float(min(rng.uniform(2.0, 5.0 if ahead else 10.0), (hard_end - cursor) / FPS))
        if direction == "forward":
            bout = pl.march(cursor, target, hard_end)
        else:
            if not side_kinds:
                side_kinds.append(
                    str(rng.choice(["side-step-out-back", "step-together", "shuffle"], p=[0.4, 0.35, 0.25]))
                )
            kind = side_kinds.pop(0)
            seen = {b.label for b in pl.bouts}
            offset = float(pl.center @ right_vec(pl.heading))
            wants = "right" if offset < 0 else "left"
            if abs(offset) > 0.15 and direction != wants and {"left", "right"} <= seen and rng.random() < 0.8:
                direction = wants
            bout = pl.side(1 if direction == "right" else -1, kind, cursor, target, hard_end)
        pl.look_during(bout)
        step_frames += bout.end + 1 - bout.start
        cursor = bout.end + 1
    return pl.finish()
