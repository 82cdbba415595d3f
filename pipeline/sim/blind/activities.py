"""What a simulated person does next: the activities and the builder that strings them together.

A :class:`ScriptBuilder` walks along the sequence and appends activities to a
:class:`~pipeline.sim.blind.script.Script`. Stepping activities plan their foot moves on a copy of
where the feet are and are kept only if they end before the sequence does; standing behaviours
write keyframed offsets (gestures, glances, a weight shift, a bow, a squat, a stretch) into the
posture channels. :func:`build_script` makes a whole person's sequence.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.sim.blind.body import Body, Style
from pipeline.sim.blind.script import LEFT, RIGHT, Bout, Move, Posture, Script, forward_of, right_of
from pipeline.sim.blind.timing import FloatArray, keyframes

SIDE_KINDS = ("out-back", "step-touch", "shuffle")
SIDE_TAGS = {"out-back": "side-step-out-back", "step-touch": "step-touch", "shuffle": "shuffle"}
STANDING = (
    "stand",
    "wave",
    "point",
    "reach",
    "look-around",
    "turn",
    "weight-shift",
    "stretch",
    "bow",
    "squat",
)
ACTIVITIES: tuple[str, ...] = (
    "march",
    *(f"{k}-{d}" for k in SIDE_KINDS for d in ("left", "right")),
    *STANDING,
)
# Relative frequency of what a person starts next (side steps split evenly into left and right).
ACTIVITY_WEIGHTS: dict[str, float] = {
    "march": 0.26,
    "out-back": 0.17,
    "step-touch": 0.14,
    "shuffle": 0.06,
    "stand": 0.04,
    "wave": 0.07,
    "point": 0.06,
    "reach": 0.04,
    "look-around": 0.07,
    "turn": 0.08,
    "weight-shift": 0.06,
    "stretch": 0.03,
    "bow": 0.02,
    "squat": 0.03,
}


@dataclass
class _Feet:
    """Where the feet are planted while a builder plans (xy metres, yaw degrees)."""

    xy: NDArray[np.float64]
    yaw: NDArray[np.float64]
    moves: list[Move] = field(default_factory=list)

    def copy(self) -> _Feet:
        return _Feet(self.xy.copy(), self.yaw.copy(), [])


class ScriptBuilder:
    """Appends activities for one person; ``build`` returns the finished :class:`Script`."""

    def __init__(
        self,
        body: Body,
        style: Style,
        rng: np.random.Generator,
        n_frames: int,
        fps: float,
        yaw0_deg: float,
        centre_xy: tuple[float, float],
    ) -> None:
        self.body, self.style, self.rng = body, style, rng
        self.n, self.fps = n_frames, fps
        self.t_s = np.arange(n_frames) / fps
        self.yaw0 = yaw0_deg
        self.yaw = yaw0_deg
        self.half_stance = 0.5 * style.stance_width_ratio * body.height_m
        c = np.asarray(centre_xy, dtype=np.float64)
        self.feet = _Feet(
            np.stack([c - self.half_stance * right_of(yaw0_deg), c + self.half_stance * right_of(yaw0_deg)]),
            np.array([yaw0_deg, yaw0_deg]),
        )
        self.feet0 = self.feet.xy.copy()
        self.posture = Posture.zeros(n_frames)
        self.bouts: list[Bout] = []
        hand = RIGHT if style.right_handed else LEFT
        self.hand = hand

    # ---- bookkeeping -------------------------------------------------------------------------

    def frame(self, t_s: float) -> int:
        return int(np.rint(t_s * self.fps))

    def fits(self, end_f: int) -> bool:
        return end_f <= self.n - 1 - int(0.3 * self.fps)

    def build(self) -> Script:
        (lx, ly), (rx, ry) = self.feet0
        return Script(
            fps=self.fps,
            n_frames=self.n,
            yaw0_deg=self.yaw0,
            feet0_xy=((float(lx), float(ly)), (float(rx), float(ry))),
            bouts=tuple(sorted(self.bouts, key=lambda b: b.start_f)),
            posture=self.posture,
        )

    def _swing(
        self,
        feet: _Feet,
        foot: int,
        t_s: float,
        dur_s: float,
        end_xy: NDArray[np.float64],
        lift_m: float,
        end_yaw: float | None = None,
        fore_aft_m: float = 0.0,
        delay_frac: float = 0.1,
        peak_frac: float | None = None,
        hold_frac: float = 0.0,
    ) -> int:
        """Plan one foot swing starting at ``t_s``; returns its touch-down frame."""
        s = self.style
        off_f = self.frame(t_s)
        on_f = max(off_f + 3, self.frame(t_s + dur_s))
        yaw_end = float(feet.yaw[foot]) if end_yaw is None else end_yaw
        pk = s.peak_frac if peak_frac is None else peak_frac
        m = Move(
            foot=foot,
            off_f=off_f,
            on_f=on_f,
            start_xy=(float(feet.xy[foot, 0]), float(feet.xy[foot, 1])),
            end_xy=(float(end_xy[0]), float(end_xy[1])),
            start_yaw_deg=float(feet.yaw[foot]),
            end_yaw_deg=yaw_end,
            lift_m=float(lift_m),
            law=s.law,
            peak_frac=pk,
            hold_frac=min(hold_frac, 0.85 - pk),
            delay_frac=delay_frac,
            fore_aft_m=fore_aft_m,
        )
        feet.moves.append(m)
        feet.xy[foot] = end_xy
        feet.yaw[foot] = yaw_end
        return on_f

    def _commit(self, plan: _Feet, tag: str, label: str, start_f: int) -> Bout | None:
        end_f = max(m.on_f for m in plan.moves)
        if not self.fits(end_f):
            return None
        self.feet = _Feet(plan.xy, plan.yaw)
        bout = Bout(tag=tag, label=label, start_f=start_f, end_f=end_f, moves=tuple(plan.moves))
        self.bouts.append(bout)
        return bout

    def _still(self, tag: str, start_s: float, end_s: float) -> Bout | None:
        end_f = self.frame(end_s)
        if not self.fits(end_f):
            return None
        bout = Bout(tag=tag, label="still", start_f=self.frame(start_s), end_f=end_f)
        self.bouts.append(bout)
        return bout

    def _add(self, channel: FloatArray, keys: list[tuple[float, float]], col: int | None = None) -> None:
        """Add a keyframed offset (keys start and end at 0) to a posture channel."""
        lo, hi = max(0, self.frame(keys[0][0])), min(self.n, self.frame(keys[-1][0]) + 1)
        if hi <= lo:
            return
        curve = keyframes(
            self.t_s[lo:hi], keys, law="minjerk" if self.style.law == "quick" else self.style.law
        )
        if col is None:
            channel[lo:hi] += curve
        else:
            channel[lo:hi, col] += curve

    def _pulse(
        self, t0: float, ramp_in: float, hold: float, ramp_out: float, value: float
    ) -> list[tuple[float, float]]:
        return [
            (t0, 0.0),
            (t0 + ramp_in, value),
            (t0 + ramp_in + hold, value),
            (t0 + ramp_in + hold + ramp_out, 0.0),
        ]

    def _u(self, lo: float, hi: float) -> float:
        return float(self.rng.uniform(lo, hi))

    # ---- stepping ----------------------------------------------------------------------------

    def march(self, start_s: float) -> Bout | None:
        """Marching in place (label ``forward``): alternate lifts at the person's cadence."""
        s, rng = self.style, self.rng
        cadence = float(np.clip(s.cadence_hz * rng.uniform(0.9, 1.1), 0.6, 2.4))
        period = 1.0 / cadence
        swing = min(max(s.swing_frac * period, 0.2), s.max_swing_s)
        swing = max(swing, period - 0.85)  # the double support stays under the 1.0 s pause rule
        n_steps = max(2, int(np.rint(self._u(3.0, 8.0) * cadence)))
        plan = self.feet.copy()
        foot = int(rng.integers(2))
        fwd, rgt = forward_of(self.yaw), right_of(self.yaw)
        t = start_s
        for _ in range(n_steps):
            dur = max(0.2, swing * rng.uniform(1 - s.timing_jitter, 1 + s.timing_jitter))
            lift = float(
                np.clip(s.march_lift_m * rng.uniform(1 - s.lift_jitter, 1 + s.lift_jitter), 0.03, 0.25)
            )
            mid = plan.xy.mean(axis=0)
            drift = s.drift_m if np.linalg.norm(mid) < 0.9 else 0.0  # creep, but stay in the CAVE
            home = mid + (1 if foot == RIGHT else -1) * self.half_stance * rgt
            end = 0.6 * plan.xy[foot] + 0.4 * home + drift * fwd + rng.normal(0.0, 0.004, 2)
            on_f = self._swing(
                plan,
                foot,
                t,
                dur,
                end,
                lift,
                fore_aft_m=s.fore_aft * lift,
                delay_frac=0.0,
                hold_frac=s.hold_frac,
            )
            t_next = t + period * rng.uniform(1 - s.timing_jitter, 1 + s.timing_jitter)
            if rng.random() < s.hesitation_p:
                t_next += self._u(0.15, 0.5)
            # at least one frame with both feet down, at most 0.93 s (the 1.0 s rule with a margin)
            t = float(np.clip(t_next, (on_f + 1) / self.fps, (on_f + 27) / self.fps))
            foot = 1 - foot
        return self._commit(plan, "march", "forward", self.frame(start_s))

    def side_steps(self, start_s: float, kind: str, direction: str) -> Bout | None:
        """A side-step bout towards ``direction`` (relative to the facing), ending where it started."""
        if kind not in SIDE_KINDS or direction not in ("left", "right"):
            raise InputError(f"unknown side step {kind}-{direction}")
        s, rng = self.style, self.rng
        lead = RIGHT if direction == "right" else LEFT
        trail = 1 - lead
        lat = (1.0 if direction == "right" else -1.0) * right_of(self.yaw)
        fwd = forward_of(self.yaw)
        width = float(np.clip(s.side_width_m * rng.uniform(0.8, 1.2), 0.10, 0.40))
        lift = float(np.clip(s.side_lift_m * rng.uniform(0.8, 1.2), 0.02, 0.12))
        swing = s.side_swing_s * rng.uniform(0.85, 1.15)
        pause_scale = 1.0
        if kind == "shuffle":  # low, quick and short
            width = float(np.clip(width * rng.uniform(0.4, 0.7), 0.08, 0.2))
            lift = self._u(0.005, 0.018)
            swing = self._u(0.2, 0.35)
            pause_scale = 0.6
        cycles = int(rng.integers(1, 4 if kind == "out-back" else 3))
        plan = self.feet.copy()
        lead_home, trail_home = plan.xy[lead].copy(), plan.xy[trail].copy()

        def pause() -> float:
            return float(np.clip(s.side_pause_s * pause_scale * rng.uniform(0.6, 1.4), 0.2, 0.9))

        def dur() -> float:
            return max(0.15, swing * rng.uniform(0.9, 1.1))

        t = start_s
        for c in range(cycles):
            out = lead_home + width * rng.uniform(0.9, 1.1) * lat + rng.normal(0.0, 0.012) * fwd
            t = self._swing(plan, lead, t, dur(), out, lift) / self.fps + pause()
            if kind == "out-back":
                on_f = self._swing(plan, lead, t, dur(), lead_home, lift)
            elif kind == "step-touch" and rng.random() < 0.4:  # tap beside the lead foot and back
                tap = trail_home + width * self._u(0.5, 0.85) * lat
                tap_lift = min(lift, self._u(0.02, 0.05))
                t = self._swing(plan, trail, t, self._u(0.2, 0.35), tap, tap_lift) / self.fps + self._u(
                    0.1, 0.25
                )
                t = self._swing(plan, trail, t, self._u(0.2, 0.35), trail_home, tap_lift) / self.fps + pause()
                on_f = self._swing(plan, lead, t, dur(), lead_home, lift)
            else:  # join: the trailing foot closes up, then both come back, trailing foot first
                joined = trail_home + (out - lead_home)
                t = self._swing(plan, trail, t, dur(), joined, lift) / self.fps + pause()
                t = self._swing(plan, trail, t, dur(), trail_home, lift) / self.fps + pause()
                on_f = self._swing(plan, lead, t, dur(), lead_home, lift)
            t = on_f / self.fps + (pause() if c < cycles - 1 else 0.0)
        return self._commit(plan, SIDE_TAGS[kind], direction, self.frame(start_s))

    def turn(self, start_s: float) -> Bout | None:
        """Turning on the spot in small pivot steps (label ``still``, tag ``turn``); the head leads."""
        rng = self.rng
        away = (self.yaw - self.yaw0 + 180.0) % 360.0 - 180.0
        sign = -math.copysign(1.0, away) if abs(away) > 60.0 else float(rng.choice([-1.0, 1.0]))
        total = sign * self._u(40.0, 150.0)
        n = max(1, math.ceil(abs(total) / self._u(25.0, 50.0)))
        lead = LEFT if total > 0 else RIGHT  # turning left (counter-clockwise): the left foot opens
        plan = self.feet.copy()
        centre = plan.xy.mean(axis=0)
        lift = self._u(0.02, 0.08)
        t = start_s
        yaw = self.yaw
        for _ in range(n):
            yaw += total / n
            for foot in (lead, 1 - lead):
                home = centre + (1 if foot == RIGHT else -1) * self.half_stance * right_of(yaw)
                on_f = self._swing(plan, foot, t, self._u(0.3, 0.55), home, lift, end_yaw=yaw)
                t = on_f / self.fps + self._u(0.05, 0.45)
        bout = self._commit(plan, "turn", "still", self.frame(start_s))
        if bout is None:
            return None
        end_s = bout.end_f / self.fps
        lead_deg = math.copysign(self._u(8.0, 25.0), total)
        self._add(
            self.posture.head_yaw_deg,
            [
                (start_s - 0.3, 0.0),
                (start_s + 0.2, lead_deg),
                (max(start_s + 0.3, end_s - 0.4), lead_deg),
                (end_s + 0.3, 0.0),
            ],
        )
        self.yaw = yaw
        return bout

    # ---- standing behaviours -----------------------------------------------------------------

    def stand(self, start_s: float) -> Bout | None:
        return self._still("", start_s, start_s + self._u(1.5, 4.0))

    def wave(self, start_s: float) -> Bout | None:
        """One arm up and out, the forearm swinging side to side."""
        arm = self.hand if self.rng.random() < 0.8 else 1 - self.hand
        up, hold, down = self._u(0.4, 0.8), self._u(1.5, 4.0), self._u(0.4, 0.8)
        end = start_s + up + hold + down
        bout = self._still("wave", start_s, end)
        if bout is None:
            return None
        p, s = self.posture, self.style
        self._add(p.arm_alpha_deg, self._pulse(start_s, up, hold, down, self._u(10.0, 40.0)), arm)
        self._add(
            p.arm_beta_deg, self._pulse(start_s, up, hold, down, self._u(110.0, 150.0) - s.arm_abd_deg), arm
        )
        self._add(p.elbow_deg, self._pulse(start_s, up, hold, down, self._u(60.0, 90.0) - s.elbow_deg), arm)
        self._add(p.arm_rot_deg, self._pulse(start_s, up, hold, down, self._u(60.0, 100.0)), arm)
        lo, hi = self.frame(start_s + up * 0.5), self.frame(start_s + up + hold)
        freq, amp = self._u(1.5, 3.0), self._u(15.0, 35.0)
        tt = self.t_s[lo:hi] - self.t_s[lo]
        fade = np.minimum(1.0, np.minimum(tt, tt[-1] - tt) / 0.2) if tt.size else tt
        p.elbow_deg[lo:hi, arm] += amp * np.sin(2 * np.pi * freq * tt) * fade
        side = 1.0 if arm == RIGHT else -1.0
        self._add(p.head_yaw_deg, self._pulse(start_s, up, hold, down, -side * self._u(0.0, 20.0)))
        return bout

    def point(self, start_s: float) -> Bout | None:
        """Pointing at one or two things, the trunk and head turning with the arm."""
        arm = self.hand if self.rng.random() < 0.85 else 1 - self.hand
        side = 1.0 if arm == RIGHT else -1.0
        t = start_s
        p, s = self.posture, self.style
        keys_a, keys_b, keys_e, keys_tw, keys_hy = ([(t, 0.0)] for _ in range(5))
        for _ in range(int(self.rng.integers(1, 3))):
            t += self._u(0.4, 0.8)
            a, b = self._u(60.0, 100.0), self._u(0.0, 45.0)
            az = -side * b  # where the arm points, counter-clockwise from the facing direction
            for keys, v in (
                (keys_a, a),
                (keys_b, b - s.arm_abd_deg),
                (keys_e, self._u(0.0, 15.0) - s.elbow_deg),
                (keys_tw, 0.3 * az),
                (keys_hy, 0.5 * az),
            ):
                keys.append((t, v))
            t += self._u(0.8, 2.5)
            for keys in (keys_a, keys_b, keys_e, keys_tw, keys_hy):
                keys.append((t, keys[-1][1]))
        t += self._u(0.4, 0.8)
        for keys in (keys_a, keys_b, keys_e, keys_tw, keys_hy):
            keys.append((t, 0.0))
        bout = self._still("point", start_s, t)
        if bout is None:
            return None
        self._add(p.arm_alpha_deg, keys_a, arm)
        self._add(p.arm_beta_deg, keys_b, arm)
        self._add(p.elbow_deg, keys_e, arm)
        self._add(p.trunk_twist_deg, keys_tw)
        self._add(p.head_yaw_deg, keys_hy)
        return bout

    def reach(self, start_s: float) -> Bout | None:
        """Reaching forwards and up with one arm (sometimes both), leaning into it."""
        up, hold, down = self._u(0.5, 1.0), self._u(0.5, 1.5), self._u(0.5, 1.0)
        bout = self._still("reach", start_s, start_s + up + hold + down)
        if bout is None:
            return None
        p, s = self.posture, self.style
        arms = (LEFT, RIGHT) if self.rng.random() < 0.3 else (self.hand,)
        for arm in arms:
            self._add(p.arm_alpha_deg, self._pulse(start_s, up, hold, down, self._u(100.0, 150.0)), arm)
            self._add(
                p.arm_beta_deg, self._pulse(start_s, up, hold, down, self._u(0.0, 30.0) - s.arm_abd_deg), arm
            )
            self._add(
                p.elbow_deg, self._pulse(start_s, up, hold, down, self._u(0.0, 20.0) - s.elbow_deg), arm
            )
        self._add(p.trunk_pitch_deg, self._pulse(start_s, up, hold, down, self._u(0.0, 12.0)))
        self._add(p.head_pitch_deg, self._pulse(start_s, up, hold, down, -self._u(5.0, 25.0)))
        return bout

    def look_around(self, start_s: float) -> Bout | None:
        """Two to four glances (head yaw and pitch, some trunk twist), then back to the front."""
        t = start_s
        keys_y, keys_p = [(t, 0.0)], [(t, 0.0)]
        for _ in range(int(self.rng.integers(2, 5))):
            t += self._u(0.4, 0.9)
            keys_y.append((t, self._u(-75.0, 75.0)))
            keys_p.append((t, self._u(-20.0, 20.0)))
            t += self._u(0.4, 1.5)
            keys_y.append((t, keys_y[-1][1]))
            keys_p.append((t, keys_p[-1][1]))
        t += self._u(0.4, 0.9)
        keys_y.append((t, 0.0))
        keys_p.append((t, 0.0))
        bout = self._still("look-around", start_s, t)
        if bout is None:
            return None
        twist = self._u(0.15, 0.4)
        self._add(self.posture.head_yaw_deg, keys_y)
        self._add(self.posture.head_pitch_deg, keys_p)
        self._add(self.posture.trunk_twist_deg, [(k, v * twist) for k, v in keys_y])
        return bout

    def weight_shift(self, start_s: float) -> Bout | None:
        """Shifting the weight onto one foot and back (or across), feet planted."""
        t = start_s
        keys = [(t, 0.0)]
        side = float(self.rng.choice([-1.0, 1.0]))
        for _ in range(int(self.rng.integers(1, 4))):
            t += self._u(0.6, 1.2)
            keys.append((t, side * self._u(0.6, 1.0)))
            t += self._u(0.8, 2.5)
            keys.append((t, keys[-1][1]))
            side = -side
        t += self._u(0.6, 1.2)
        keys.append((t, 0.0))
        bout = self._still("weight-shift", start_s, t)
        if bout is None:
            return None
        self._add(self.posture.weight_bias, keys)
        return bout

    def stretch(self, start_s: float) -> Bout | None:
        """Both arms overhead (from the front or from the sides), back arched or bent sideways."""
        up, hold, down = self._u(0.8, 1.5), self._u(1.0, 3.0), self._u(0.8, 1.5)
        bout = self._still("stretch", start_s, start_s + up + hold + down)
        if bout is None:
            return None
        p, s = self.posture, self.style
        front = self.rng.random() < 0.5
        for arm in (LEFT, RIGHT):
            a, b = (
                (self._u(150.0, 175.0), self._u(0.0, 15.0))
                if front
                else (self._u(0.0, 20.0), self._u(150.0, 170.0))
            )
            self._add(p.arm_alpha_deg, self._pulse(start_s, up, hold, down, a), arm)
            self._add(p.arm_beta_deg, self._pulse(start_s, up, hold, down, b - s.arm_abd_deg), arm)
            self._add(
                p.elbow_deg, self._pulse(start_s, up, hold, down, self._u(0.0, 20.0) - s.elbow_deg), arm
            )
        if self.rng.random() < 0.5:
            self._add(p.trunk_pitch_deg, self._pulse(start_s, up, hold, down, -self._u(3.0, 12.0)))
        else:
            self._add(
                p.trunk_roll_deg,
                self._pulse(start_s, up, hold, down, float(self.rng.choice([-1, 1])) * self._u(8.0, 20.0)),
            )
        self._add(p.head_pitch_deg, self._pulse(start_s, up, hold, down, -self._u(5.0, 20.0)))
        return bout

    def bow(self, start_s: float) -> Bout | None:
        """A bow from the hips; the pelvis moves back to keep balance, arms hang."""
        down, hold, up = self._u(0.6, 1.2), self._u(0.3, 1.5), self._u(0.6, 1.2)
        bout = self._still("bow", start_s, start_s + down + hold + up)
        if bout is None:
            return None
        p = self.posture
        pitch = self._u(25.0, 55.0)
        self._add(p.trunk_pitch_deg, self._pulse(start_s, down, hold, up, pitch))
        self._add(p.pelvis_back_m, self._pulse(start_s, down, hold, up, self._u(0.04, 0.10) * pitch / 45.0))
        self._add(p.pelvis_drop_m, self._pulse(start_s, down, hold, up, self._u(0.0, 0.03)))
        self._add(p.head_pitch_deg, self._pulse(start_s, down, hold, up, self._u(0.0, 15.0)))
        return bout

    def squat(self, start_s: float) -> Bout | None:
        """A squat, heels down: pelvis low and back, trunk forward, arms forward for balance."""
        down, hold, up = self._u(0.8, 1.5), self._u(0.3, 2.0), self._u(0.8, 1.5)
        bout = self._still("squat", start_s, start_s + down + hold + up)
        if bout is None:
            return None
        p = self.posture
        self._add(
            p.pelvis_drop_m, self._pulse(start_s, down, hold, up, self._u(0.10, 0.17) * self.body.height_m)
        )
        self._add(p.pelvis_back_m, self._pulse(start_s, down, hold, up, self._u(0.08, 0.18)))
        self._add(p.trunk_pitch_deg, self._pulse(start_s, down, hold, up, self._u(15.0, 40.0)))
        for arm in (LEFT, RIGHT):
            self._add(p.arm_alpha_deg, self._pulse(start_s, down, hold, up, self._u(30.0, 60.0)), arm)
        return bout

    # ---- dispatch ----------------------------------------------------------------------------

    def perform(self, activity: str, start_s: float) -> Bout | None:
        """Append ``activity`` (one of ACTIVITIES) at ``start_s``; None when it does not fit in."""
        if activity == "march":
            return self.march(start_s)
        for kind in SIDE_KINDS:
            for direction in ("left", "right"):
                if activity == f"{kind}-{direction}":
                    return self.side_steps(start_s, kind, direction)
        behaviours = {
            "stand": self.stand,
            "wave": self.wave,
            "point": self.point,
            "reach": self.reach,
            "look-around": self.look_around,
            "turn": self.turn,
            "weight-shift": self.weight_shift,
            "stretch": self.stretch,
            "bow": self.bow,
            "squat": self.squat,
        }
        if activity not in behaviours:
            raise InputError(f"unknown activity {activity!r}; expected one of {list(ACTIVITIES)}")
        return behaviours[activity](start_s)


def draw_activity(rng: np.random.Generator) -> str:
    """A random activity by ACTIVITY_WEIGHTS (side steps get a random direction)."""
    names = list(ACTIVITY_WEIGHTS)
    w = np.array([ACTIVITY_WEIGHTS[n] for n in names])
    name = str(rng.choice(names, p=w / w.sum()))
    if name in SIDE_KINDS:
        return f"{name}-{rng.choice(['left', 'right'])}"
    return name


def build_script(
    body: Body,
    style: Style,
    rng: np.random.Generator,
    n_frames: int,
    fps: float,
    yaw0_deg: float,
    centre_xy: tuple[float, float],
    activities: tuple[str, ...] | None = None,
) -> Script:
    """A person's whole sequence: the given activities in order, or random ones until it is full.

    A random sequence starts with a march, a side-step bout to each side, a turn and two different
    standing behaviours (in random order), then random activities follow; activities are
    separated by plain standing (0.6–2.5 s; at least 1.2 s after a stepping bout, so two bouts never
    merge into one label run).
    """
    b = ScriptBuilder(body, style, rng, n_frames, fps, yaw0_deg, centre_xy)
    duration = n_frames / fps
    t = float(rng.uniform(0.5, 1.5))
    if activities is not None:
        for name in activities:
            bout = b.perform(name, t)
            if bout is None:
                raise InputError(f"the activities {list(activities)} do not fit in {duration:.1f} s")
            t = bout.end_f / fps + float(rng.uniform(1.2, 2.0))
        return b.build()
    gestures = [a for a in STANDING if a not in ("stand", "turn")]
    must = [
        "march",
        f"{rng.choice(['out-back', 'step-touch'])}-left",
        f"{rng.choice(['out-back', 'step-touch'])}-right",
        "turn",
        *(str(a) for a in rng.choice(gestures, size=2, replace=False)),
    ]
    rng.shuffle(must)
    queue = list(must)  # the required ones first, then random ones
    misses = 0
    while t < duration - 1.0 and misses < 6:
        name = queue.pop(0) if queue else draw_activity(rng)
        bout = b.perform(name, t)
        if bout is None:
            misses += 1
            continue
        stepping = bout.label != "still" or bout.moves
        t = bout.end_f / fps + float(rng.uniform(1.2 if stepping else 0.6, 2.5))
    return b.build()
