"""The blind2 feet: foot events and the ankle paths they make.

A foot is moved only by events. A *swing* goes from lift-off to touch-down: its horizontal path is
a minimum-jerk ramp that lags the lift a little, and its height is either a sin² lift profile
(side steps, pivots) or, for marching, the ankle offset from a hip-flexion / shank-angle profile
(forward kinematics of thigh and shank). A *slide* creeps a planted foot along the floor. A
planted ankle is exactly at its standing height, and a foot is in contact except strictly between
lift-off and touch-down.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pipeline.sim.blind2.profiles import bump, min_jerk

F64 = NDArray[np.float64]


@dataclass(frozen=True, slots=True, eq=False)
class FootEvent:
    """One move of one foot over frames start…end (inclusive), from p0 to p1 (xy, m), yaw y0 to y1 (rad).

    kind: ``swing`` (the foot leaves the floor) or ``slide`` (it creeps, planted). For a swing:
    lift_m, the peak height of a ``lift`` style swing; style ``march`` lifts the foot by the leg's
    hip flexion hip_flex_rad and shank angle shank_rad instead; skew > 1 delays the swing's middle.
    """

    kind: Literal["swing", "slide"]
    start: int
    end: int
    p0: F64
    p1: F64
    y0: float
    y1: float
    lift_m: float = 0.0
    style: Literal["lift", "march"] = "lift"
    skew: float = 1.0
    hip_flex_rad: float = 0.0
    shank_rad: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in ("swing", "slide"):
            raise ValueError(f"kind must be 'swing' or 'slide', got {self.kind!r}")
        if self.style not in ("lift", "march"):
            raise ValueError(f"style must be 'lift' or 'march', got {self.style!r}")
        if not 0 <= self.start < self.end:
            raise ValueError(f"an event needs 0 <= start < end, got {self.start}, {self.end}")
        if np.shape(self.p0) != (2,) or np.shape(self.p1) != (2,):
            raise ValueError(
                f"p0 and p1 must be (2,) xy points, got {np.shape(self.p0)}, {np.shape(self.p1)}"
            )
        if self.skew <= 0 or self.lift_m < 0:
            raise ValueError(f"skew must be positive and lift_m not negative, got {self.skew}, {self.lift_m}")


@dataclass(frozen=True, slots=True, eq=False)
class FeetSnapshot:
    """Where the feet stood and how many events each had, to undo a plan that did not fit."""

    n_events: tuple[int, int]
    pos: tuple[F64, F64]
    yaw: tuple[float, float]


class FootTrack:
    """The two feet while a script is planned: their events so far and where they end up."""

    __slots__ = ("events", "init_pos", "init_yaw", "pos", "yaw")

    def __init__(self, pos: tuple[F64, F64], yaw: tuple[float, float]) -> None:
        self.pos: list[F64] = [p.copy() for p in pos]
        self.yaw: list[float] = list(yaw)
        self.init_pos: tuple[F64, F64] = (pos[0].copy(), pos[1].copy())
        self.init_yaw: tuple[float, float] = (yaw[0], yaw[1])
        self.events: tuple[list[FootEvent], list[FootEvent]] = ([], [])

    def facing(self) -> float:
        """The mean of the two foot yaws (rad)."""
        return 0.5 * (self.yaw[0] + self.yaw[1])

    def centre(self) -> F64:
        """(2,) the midpoint of the feet."""
        return 0.5 * (self.pos[0] + self.pos[1])

    def snapshot(self) -> FeetSnapshot:
        return FeetSnapshot(
            (len(self.events[0]), len(self.events[1])),
            (self.pos[0].copy(), self.pos[1].copy()),
            (self.yaw[0], self.yaw[1]),
        )

    def restore(self, snap: FeetSnapshot) -> None:
        """Drop the events planned since ``snap`` and put the feet back."""
        for f in range(2):
            del self.events[f][snap.n_events[f] :]
        self.pos = [snap.pos[0].copy(), snap.pos[1].copy()]
        self.yaw = [snap.yaw[0], snap.yaw[1]]

    def swing(
        self,
        f: int,
        a: int,
        dur: int,
        p1: ArrayLike,
        y1: float | None = None,
        lift: float = 0.05,
        style: Literal["lift", "march"] = "lift",
        skew: float = 1.0,
        hip_flex_rad: float = 0.0,
        shank_rad: float = 0.0,
    ) -> int:
        """Swing foot f from frame a to p1 (and yaw y1) in ``dur`` frames; the touch-down frame."""
        b = a + max(2, dur)
        if y1 is None:
            y1 = self.yaw[f]
        end = np.asarray(p1, float).copy()
        p0, y0 = self.pos[f].copy(), self.yaw[f]
        self.events[f].append(
            FootEvent("swing", a, b, p0, end.copy(), y0, y1, lift, style, skew, hip_flex_rad, shank_rad)
        )
        self.pos[f] = end
        self.yaw[f] = y1
        return b

    def slide(self, f: int, a: int, b: int, dp: F64) -> None:
        """Creep planted foot f by dp (xy, m) over frames a…b (nothing if that is under 3 frames)."""
        if b - a < 3:
            return
        p1 = self.pos[f] + dp
        self.events[f].append(
            FootEvent("slide", a, b, self.pos[f].copy(), p1.copy(), self.yaw[f], self.yaw[f])
        )
        self.pos[f] = p1


@dataclass(frozen=True, slots=True, eq=False)
class FeetMotion:
    """The feet over T frames, index 0 = left: ankle_m (2, T, 3) ankle centres, yaw (2, T) rad,
    contact (2, T) bool, lift_env (2, T) the swing bump 0…1 (0 when planted)."""

    ankle_m: F64
    yaw: F64
    contact: NDArray[np.bool_]
    lift_env: F64

    def __post_init__(self) -> None:
        n = self.ankle_m.shape[1] if self.ankle_m.ndim == 3 else -1
        if self.ankle_m.shape != (2, n, 3) or any(
            x.shape != (2, n) for x in (self.yaw, self.contact, self.lift_env)
        ):
            raise ValueError(
                "expected ankle_m (2, T, 3) and yaw, contact, lift_env (2, T), got "
                f"{self.ankle_m.shape}, {self.yaw.shape}, {self.contact.shape}, {self.lift_env.shape}"
            )


def render_feet(
    track: FootTrack, n_frames: int, ankle_height_m: float, thigh_m: float, shank_m: float
) -> FeetMotion:
    """The ankle paths, yaws, contacts and lift envelopes that the track's events make."""
    T, ah = n_frames, ankle_height_m
    P = np.zeros((2, T, 3))
    Y = np.zeros((2, T))
    C = np.ones((2, T), bool)
    E = np.zeros((2, T))
    l1, l2 = thigh_m, shank_m
    for f in range(2):
        pos, yaw, last = track.init_pos[f].copy(), track.init_yaw[f], 0
        evs = sorted(track.events[f], key=lambda e: e.start)
        for e in evs:
            a, b = e.start, e.end
            if a < last:
                raise RuntimeError(f"overlapping events of foot {f} at frame {a}")
            if b >= T:
                raise RuntimeError(f"an event of foot {f} ends at frame {b}, after the last frame {T - 1}")
            P[f, last:a, :2] = pos
            Y[f, last:a] = yaw
            tt = (np.arange(a, b + 1) - a) / (b - a)
            if e.kind == "slide":
                h = min_jerk(tt)
                P[f, a : b + 1, :2] = e.p0 + h[:, None] * (e.p1 - e.p0)
                Y[f, a : b + 1] = yaw
            else:
                ts = tt**e.skew
                h = min_jerk((ts - 0.1) / 0.8)
                yy = e.y0 + min_jerk(ts) * (e.y1 - e.y0)
                xy = e.p0 + h[:, None] * (e.p1 - e.p0)
                env = bump(ts)
                if e.style == "march":
                    th = e.hip_flex_rad * env
                    ph = e.shank_rad * env
                    fo = l1 * np.sin(th) - l2 * np.sin(ph)
                    up = (l1 + l2) - l1 * np.cos(th) - l2 * np.cos(ph)
                    fv = np.stack([-np.sin(yy), np.cos(yy)], -1)
                    xy = xy + fv * fo[:, None]
                    z = up
                else:
                    z = e.lift_m * env
                P[f, a : b + 1, :2] = xy
                P[f, a : b + 1, 2] = z
                Y[f, a : b + 1] = yy
                C[f, a + 1 : b] = False
                E[f, a : b + 1] = env
            pos, yaw, last = e.p1.copy(), e.y1, b + 1
        P[f, last:, :2] = pos
        Y[f, last:] = yaw
    P[..., 2] += ah
    return FeetMotion(ankle_m=P, yaw=Y, contact=C, lift_env=E)
