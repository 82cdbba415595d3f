"""Step evidence from the 3D skeleton: per-foot contact, lift-off and touch-down events, and the
stepping foot's displacement in the body frame. Readable facts next to the network.

What a person can check on the dashboard's step strip, and what the recogniser's gate uses
("no movement command without a foot lifting or sliding"):

- **Body scale** ``leg_m``: the running median-like average of hip-knee + knee-ankle, so every
  threshold below is a fraction of the person's own leg (tall and short people alike).
- **Per-foot anchor and standing level**: while a foot is planted its ankle position is
  followed slowly (the anchor; slow drift such as a heel rising in a squat stays "planted");
  the foot's standing level is the lower envelope of its planted heights (no floor height is
  assumed: it is estimated online, per person and per foot).
- **Lift-off**: the smoothed ankle leaves its anchor faster than the anchor follows, upwards by
  ``lift_up`` legs or sideways/forwards by ``lift_side`` legs (a slide or shuffle without a
  visible lift counts). Its time is back-dated to where the departure began.
- **Touch-down**: the swinging ankle is still again (its last ``land_window_s`` within a small
  box) near its standing level, or still for ``hold_s`` anywhere (a raised foot held still: a
  kneel's back foot, tiptoes). Back-dated to where the stillness began.
- **Jump**: both feet lift off within ``jump_sync_s`` of each other: neither swing is a step.
- **Displacement** of a swinging foot since its lift-off, in the body frame at lift-off
  (lateral +right, sagittal +forward, vertical +up), and its kind: ``vertical`` (a march),
  ``forward`` or ``backward`` (a step along the facing), ``open`` / ``close`` (sideways away
  from / towards the other foot; an opening step's side is the side-step direction), ``small``.
- **Crouch**: the pelvis is lower than ``crouch_ratio`` of its standing height above the feet with
  both knees bent (a straight leg, hip to ankle ``crouch_straight`` of thigh + shank or more, is a
  wide stance: the pelvis drops in a wide side step without any crouch).
- **Upright**: the trunk (mid-hips to mid-shoulders) is within ``max_tilt_deg`` of vertical; a
  body bent far over, lying or crawling is not upright (an unfamiliar posture: no step counts).

Noise: the ankle goes through a median of three frames (single-frame outliers vanish) and an
EMA; jumps larger than ``outlier_legs`` are ignored; each foot's jitter while planted is measured
and raises the thresholds of that foot; unknown joints hold the last state (a foot unknown
longer than ``lost_s`` is reported ``known=False`` and never starts a step). A foot's first frames
(a new navigator, or after a reset): no lift-off before its median of three runs, and a lone
outlier in its first frame (ankle or knee, off the next two points that agree) is neither its
anchor nor its knee-ankle baseline: finding a standing person is no step.
:class:`StepTracker` is the streaming form (one frame at a time, the recogniser's);
:func:`step_evidence` runs it over a whole sequence.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.numbers import rounded
from pipeline.skeleton import NUM_JOINTS, J

FEET = ("left", "right")
KINDS = ("none", "small", "vertical", "forward", "backward", "open", "close")
SIDEWAYS_KINDS = ("open", "close")  # a foot moving away from or towards the other one
_ANKLE = (J["l_ankle"], J["r_ankle"])
_KNEE = (J["l_knee"], J["r_knee"])
_HIP = (J["l_hip"], J["r_hip"])
_SHOULDER = (J["l_shoulder"], J["r_shoulder"])
_Rows = Sequence[Sequence[float]]  # one skeleton's (17, 3) joints as plain floats
DEFAULT_LEG_M = 0.85
_MAD_SIGMA = 1.4826 / math.sqrt(6.0)  # sigma of white noise from the median |second difference|
_JITTER_SAMPLES = 15  # raw second differences of a foot before its jitter (sigma) is measured


_KNEE_AGREE_LEGS = 0.04  # a foot's first three knee-ankle heights: see _lone_first


def _lone_first(samples: Sequence[float], tol: float) -> bool:
    """The first of three samples was an outlier: the other two agree within ``tol`` and the first
    lies more than twice ``tol`` from both."""
    a, b, c = samples[0], samples[1], samples[2]
    return abs(b - c) < tol and abs(a - b) > 2 * tol and abs(a - c) > 2 * tol


def _median(values: deque[float]) -> float:
    s = sorted(values)
    return s[len(s) // 2]


@dataclass(frozen=True, slots=True)
class StepConfig:
    """Thresholds of the step evidence; lengths are fractions of the person's leg length.

    smooth_alpha: weight of a new ankle position in its EMA (per frame at ``rate_hz``).
    anchor_tau_s: how slowly a planted foot's anchor follows its ankle.
    lift_up / lift_side: departure from the anchor, up / horizontally, that is a lift-off; at least
        ``noise_k`` times the foot's own measured raw jitter (sigma) while planted (so noisier capture needs a
        clearer lift), and reached within ``max_rise_s`` (a slow drift, a heel rising in a squat,
        moves the anchor instead).
    land_window_s, land_box: a swinging foot whose last land_window_s stayed within land_box
        (legs, per axis) is still; it has touched down if it is within land_height of its standing
        level, or if it stays still for hold_s anywhere; a short stance (running) also counts when
        the raw foot point of the last three frames stayed within raw_land_k of its jitter, near the
        standing level.
    jump_sync_s: two lift-offs this close together are a jump, not a step.
    min_swing_s: shortest swing (a touch-down sooner is noise); max_swing_s: a longer one ends
        where the foot is (a leg held up).
    crouch_ratio: pelvis height above the feet below this share of its standing height = crouched,
        unless a leg is straight: its hip-to-ankle distance at least ``crouch_straight`` of thigh +
        shank (a wide stance; a crouch, squat or kneel bends both knees).
    outlier_legs: a frame-to-frame ankle jump larger than this is ignored (a triangulation outlier).
    lost_s: a foot unknown for longer is reported unknown.
    rate_hz: the frame rate the per-frame weights are given for.
    defer_landing: a swing lands at the earliest in the frame after its lift-off (once the foot's
        jitter is measured: before that a departure and return within one frame is jitter). Off, a
        slow move along the floor could lift off (back-dated) and land within one frame, and the
        step was never reported (a shuffle's slides; the committed networks were trained so).
    turn_far / turn_low / turn_split: a swing that went ``turn_far`` (legs) or more sideways and
        inwards (towards the other foot) from its lift-off, low at its farthest point (under
        ``turn_low`` legs or the lift-off height threshold above the standing level: the smoothed
        ankle of a two- or three-frame touch-down stays 2-3 cm up) and coming back out by the
        horizontal lift-off threshold touched down there and lifted off again: two steps (a way
        back, or a step-together's follow, and the next step out at once; merged, they cancel and
        the step looks like a march). A tap out and straight back (a dance's) and a sagittal
        turnaround (a kick, a treadmill's stance) stay one swing. ``turn_split`` off: one swing
        (before 2026-12-06 midday).
    """

    smooth_alpha: float = 0.6
    anchor_tau_s: float = 0.7
    lift_up: float = 0.025
    lift_side: float = 0.06
    noise_k: float = 2.2
    max_rise_s: float = 0.4
    land_window_s: float = 0.1
    land_box: float = 0.015
    land_height: float = 0.012
    hold_s: float = 0.3
    raw_land_k: float = 3.0
    max_swing_s: float = 2.5
    jump_sync_s: float = 0.15
    min_swing_s: float = 0.1
    crouch_ratio: float = 0.82
    crouch_straight: float = 0.94
    max_tilt_deg: float = 50.0
    outlier_legs: float = 0.3
    lost_s: float = 0.3
    floor_tau_s: float = 4.0
    standing_tau_s: float = 8.0
    yaw_alpha: float = 0.3
    rate_hz: float = 30.0
    defer_landing: bool = True
    turn_far: float = 0.09
    turn_low: float = 0.04
    turn_split: bool = True

    def __post_init__(self) -> None:
        for name in ("smooth_alpha", "yaw_alpha"):
            v = getattr(self, name)
            if not 0 < v <= 1:
                raise ValueError(f"{name} must be in (0, 1], got {v}")
        for name in (
            "anchor_tau_s", "lift_up", "lift_side", "noise_k", "max_rise_s", "land_window_s", "land_box",
            "land_height", "hold_s", "raw_land_k", "max_swing_s", "jump_sync_s", "outlier_legs", "lost_s",
            "floor_tau_s",
            "standing_tau_s", "rate_hz", "max_tilt_deg", "turn_far", "turn_low",
        ):  # fmt: skip
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number, got {v}")
        if not 0 < self.crouch_ratio < 1:
            raise ValueError(f"crouch_ratio must be in (0, 1), got {self.crouch_ratio}")
        if not 0 < self.crouch_straight <= 1:
            raise ValueError(f"crouch_straight must be in (0, 1], got {self.crouch_straight}")
        if self.min_swing_s < 0:
            raise ValueError(f"min_swing_s must be >= 0, got {self.min_swing_s}")


@dataclass(frozen=True, slots=True)
class FootState:
    """One foot in one frame.

    known: the ankle was seen recently. planted: in contact (not swinging). rising: planted but
        already half-way to a lift-off (the other foot of a jump that is taking off).
    lifted / landed: a lift-off / touch-down was detected in this frame (``event_t`` its
        back-dated time, seconds).
    height_m: ankle height above the foot's standing level.
    swing_s: time since lift-off (0 while planted).
    lateral_m / sagittal_m / vertical_m: displacement since lift-off in the body frame at lift-off
        (+right, +forward, +up; the peak height for vertical); the last step's while planted.
    kind: what the current (or last) step looks like, one of KINDS.
    jump: the current (or last) swing was part of a jump (both feet together).
    turn_deg: how far the body turned (yaw, counter-clockwise +) since lift-off: a pivot step of
        a turn on the spot turns the body, a step of walking or marching hardly does.
    split_m: at the current (or last) lift-off, how far this foot stood ahead of the other one in the
        body frame (negative: behind; a kneel's split stance is 0.4-0.6 m), NaN unknown.
    raise_deg: how far the leg is raised from straight down (hip to ankle, forward or to a side;
        a leg behind the hip counts only sideways): a kick raises it 60-90 degrees, a march step
        with a high knee or a walking stride about 25-40 (the ankle stays under the knee). NaN
        unknown.
    """

    known: bool
    planted: bool
    rising: bool
    lifted: bool
    landed: bool
    event_t: float
    height_m: float
    swing_s: float
    lateral_m: float
    sagittal_m: float
    vertical_m: float
    kind: str
    jump: bool
    turn_deg: float = 0.0
    raise_deg: float = math.nan
    split_m: float = math.nan


@dataclass(frozen=True, slots=True)
class StepFrame:
    """The step evidence of one frame (what the step strip shows).

    feet: (left, right). leg_m: the body scale used. crouched: pelvis low (crouch, squat, kneel).
    pelvis_ratio: pelvis height above the feet / its standing height.
    stepping: index of the foot whose step is the newest (0 left, 1 right), -1 before any.
    last_land_t: time of the newest touch-down (NaN before any); last_lift_t: newest lift-off.
    upright / tilt_deg: the trunk's lean from vertical. yaw_deg: the body's facing (smoothed,
        unwrapped: a whole turn adds 360; NaN before the hips and shoulders were seen).
    """

    t: float
    feet: tuple[FootState, FootState]
    leg_m: float
    crouched: bool
    pelvis_ratio: float
    stepping: int
    last_lift_t: float
    last_land_t: float
    upright: bool = True
    tilt_deg: float = 0.0
    yaw_deg: float = math.nan

    @property
    def both_planted(self) -> bool:
        return self.feet[0].planted and self.feet[1].planted

    def to_dict(self) -> dict[str, object]:
        """JSON-ready (the live status and the step strip)."""

        return {
            "t": rounded(self.t),
            "feet": [
                {
                    "foot": name,
                    "known": bool(f.known),
                    "planted": bool(f.planted),
                    "rising": bool(f.rising),
                    "lifted": bool(f.lifted),
                    "landed": bool(f.landed),
                    "height_m": rounded(f.height_m),
                    "swing_s": rounded(f.swing_s),
                    "lateral_m": rounded(f.lateral_m),
                    "sagittal_m": rounded(f.sagittal_m),
                    "vertical_m": rounded(f.vertical_m),
                    "kind": f.kind,
                    "jump": bool(f.jump),
                    "turn_deg": rounded(f.turn_deg, 1),
                    "raise_deg": rounded(f.raise_deg, 1),
                    "split_m": rounded(f.split_m),
                }
                for name, f in zip(FEET, self.feet, strict=True)
            ],
            "leg_m": rounded(self.leg_m),
            "crouched": bool(self.crouched),
            "pelvis_ratio": rounded(self.pelvis_ratio),
            "upright": bool(self.upright),
            "tilt_deg": rounded(self.tilt_deg, 1),
            "yaw_deg": rounded(self.yaw_deg, 1),
            "stepping": FEET[int(self.stepping)] if self.stepping >= 0 else None,
        }


# ---------------------------------------------------------------- pure pieces


def body_axes(yaw_rad: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """(right, forward) unit vectors on the floor of a body facing ``yaw`` (0 = +Y, CCW positive)."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return (c, s), (-s, c)


def step_kind(
    foot: int, lateral: float, sagittal: float, vertical: float, leg_m: float, config: StepConfig
) -> str:
    """What a foot's displacement since lift-off looks like (see the module docstring).

    ``foot`` 0 = left (outward = -lateral), 1 = right (outward = +lateral).
    """
    lat, sag, up = lateral / leg_m, sagittal / leg_m, vertical / leg_m
    side_min, up_min = config.lift_side, config.lift_up
    horiz = math.hypot(lat, sag)
    if abs(lat) >= side_min and abs(lat) >= 1.2 * abs(sag) and abs(lat) >= 0.6 * up:
        outward = -lat if foot == 0 else lat
        return "open" if outward > 0 else "close"
    if abs(sag) >= side_min and abs(sag) >= 1.2 * abs(lat) and abs(sag) >= 0.6 * up:
        return "forward" if sag > 0 else "backward"
    if up >= up_min and horiz < max(side_min, 0.9 * up):
        return "vertical"
    if horiz > 0.5 * side_min or up > 0.5 * up_min:
        return "small"
    return "none"


def raw_facing_yaw(joints: NDArray[np.float64] | _Rows) -> float:
    """Facing yaw (radians, 0 = +Y, CCW) of one skeleton (17, 3) from hips and shoulders; NaN if
    unknown."""
    vx = vy = 0.0
    n = 0
    for li, ri in (_HIP, _SHOULDER):
        dx = joints[li][0] - joints[ri][0]
        dy = joints[li][1] - joints[ri][1]
        norm = math.hypot(dx, dy)
        if math.isfinite(norm) and norm > 1e-6:
            # left-minus-right turned clockwise by 90 degrees is the facing direction
            vx += dy / norm
            vy += -dx / norm
            n += 1
    if n == 0 or math.hypot(vx, vy) < 1e-9:
        return math.nan
    return math.atan2(-vx, vy)


# ---------------------------------------------------------------- the streaming tracker


class _Foot:
    """Mutable per-foot state of :class:`StepTracker`."""

    def __init__(self) -> None:
        self.pos: list[float] | None = None  # smoothed ankle x, y, z
        self.raw: deque[tuple[float, float, float]] = deque(maxlen=3)
        self.shank: float | None = None  # knee minus ankle height while planted (running mean)
        self.first_points: list[tuple[float, float, float, float]] = []  # first three (x, y, z, shank)
        # jitter (sigma, m) of the raw foot point, vertical and per horizontal axis, from the
        # median absolute second difference over the last 3 s
        self.dev_z: deque[float] = deque(maxlen=90)
        self.dev_h: deque[float] = deque(maxlen=180)
        self.n_dev = 0
        self.sigma_z = 0.02  # conservative until measured
        self.sigma_h = 0.02
        self.seen_t = -math.inf
        self.hist: deque[tuple[float, float, float, float]] = deque(maxlen=64)  # (t, x, y, z)
        self.planted = True
        self.anchor: list[float] | None = None
        self.first_checked = True  # the first three raw points were looked at for an outlier
        self.floor: float | None = None
        self.lift_t = -math.inf
        self.land_t = -math.inf
        self.lift_pos = (0.0, 0.0, 0.0)
        self.lift_axes = ((1.0, 0.0), (0.0, 1.0))
        self.lift_yaw = 0.0
        self.turn = 0.0
        self.still_since = math.nan
        self.lateral = self.sagittal = self.vertical = 0.0
        self.kind = "none"
        self.jump = False
        self.outliers = 0
        self.split = math.nan  # at the current (or last) lift-off: how far ahead of the other foot (m)
        self.far = 0.0  # the current swing's farthest horizontal distance from its lift-off (m) ...
        self.far_pos = (0.0, 0.0, 0.0)  # ... where the smoothed ankle was then ...
        self.far_t = -math.inf  # ... and when


def _from_lift(f: _Foot, pos: Sequence[float]) -> tuple[float, float]:
    """(lateral, sagittal) metres of ``pos`` from foot ``f``'s lift-off point, in the body frame of
    that lift-off (+right, +forward)."""
    (rx, ry), (fx, fy) = f.lift_axes
    dx, dy = pos[0] - f.lift_pos[0], pos[1] - f.lift_pos[1]
    return dx * rx + dy * ry, dx * fx + dy * fy


class StepTracker:
    """Streaming step evidence: ``update(joints (17, 3), t)`` -> :class:`StepFrame` per frame."""

    def __init__(self, config: StepConfig | None = None) -> None:
        self.config = config or StepConfig()
        self.reset()

    def reset(self) -> None:
        self._feet = (_Foot(), _Foot())
        self._leg = DEFAULT_LEG_M
        self._leg_n = 0
        self._yaw: float | None = None
        self._t: float | None = None
        self._standing: float | None = None
        self._pelvis_ratio = 1.0
        self._straight = math.nan
        self._tilt = 0.0
        self._stepping = -1
        self._last_lift_t = math.nan
        self._last_land_t = math.nan

    # -- helpers

    def _w(self, tau_s: float, dt: float) -> float:
        return 1.0 - math.exp(-dt / tau_s)

    def _update_scale(self, j: _Rows) -> None:
        vals, straight = [], []
        for s in (0, 1):
            a = math.dist(j[_HIP[s]], j[_KNEE[s]]) + math.dist(j[_KNEE[s]], j[_ANKLE[s]])
            if math.isfinite(a):
                vals.append(a)
                if a > 0:
                    straight.append(math.dist(j[_HIP[s]], j[_ANKLE[s]]) / a)
        if straight:  # the straighter leg's hip-to-ankle distance / thigh + shank (held while unknown)
            self._straight = max(straight)
        if not vals:
            return
        v = sum(vals) / len(vals)
        if not 0.45 <= v <= 1.4:
            return
        self._leg_n += 1
        if self._leg_n <= 30:  # the mean of the first second, then a slow follower clipped at 10 %
            self._leg += (v - self._leg) / self._leg_n if self._leg_n > 1 else v - self._leg
        else:
            self._leg += 0.02 * min(max(v - self._leg, -0.1 * self._leg), 0.1 * self._leg)

    def _update_yaw(self, j: _Rows) -> None:
        yaw = raw_facing_yaw(j)
        if not math.isfinite(yaw):
            return
        if self._yaw is None:
            self._yaw = yaw
            return
        d = (yaw - self._yaw + math.pi) % (2 * math.pi) - math.pi
        self._yaw += self.config.yaw_alpha * d

    # -- per foot

    def _foot_point(
        self, f: _Foot, ankle: Sequence[float], knee: Sequence[float], dt: float
    ) -> tuple[float, float, float] | None:
        """The ankle, with the quick part of its height averaged with the knee's (a lift raises both
        alike, so the noise shrinks and the lift stays)."""
        x, y, z = ankle
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
            return None
        kz = knee[2]
        if len(f.first_points) < 3:
            f.first_points.append((x, y, z, kz - z))
            shanks = [p[3] for p in f.first_points]
            known = len(shanks) == 3 and all(map(math.isfinite, shanks))
            if known and _lone_first(shanks, _KNEE_AGREE_LEGS * self._leg):  # a first-frame knee outlier
                f.shank = 0.5 * (shanks[1] + shanks[2])  # is not the knee-ankle baseline
        if math.isfinite(kz):
            shank = kz - z
            if f.shank is None:
                f.shank = shank
            else:  # fast: posture (a shank tilting in a crouch) is followed, only noise is averaged
                f.shank += self._w(0.3, dt) * (shank - f.shank)
            z += 0.5 * (shank - f.shank)
        return x, y, z

    def _smooth(self, f: _Foot, point: tuple[float, float, float] | None, t: float, dt: float) -> bool:
        """Update the smoothed foot point; False when it is unknown or an outlier."""
        c = self.config
        if point is None:
            return False
        x, y, z = point
        if f.pos is None or t - f.seen_t > c.lost_s:
            f.pos = [x, y, z]
            f.hist.clear()
            f.raw.clear()
            f.raw.append((x, y, z))
            f.outliers = 0
        else:
            # the distance from where the foot was heading (its last raw step continued): a fast
            # foot (running) moves far between frames, a triangulation outlier jumps off its path
            guess: tuple[float, ...] = tuple(f.raw[-1] if f.raw else f.pos)
            if len(f.raw) >= 2 and f.outliers == 0:
                guess = tuple(2 * a - b for a, b in zip(f.raw[-1], f.raw[-2], strict=True))
            jump = min(math.dist(guess, (x, y, z)), math.dist(f.pos, (x, y, z)))
            allowed = c.outlier_legs * self._leg * max(1.0, dt * c.rate_hz)
            if jump > allowed and f.outliers < 2:
                f.outliers += 1
                return False
            f.outliers = 0
            f.raw.append((x, y, z))
            if len(f.raw) == 3:  # jitter from the raw second difference: smooth motion hardly counts
                (x0, y0, z0), (x1, y1, z1) = f.raw[0], f.raw[1]
                f.dev_z.append(abs(z - 2 * z1 + z0))
                f.dev_h.append(abs(x - 2 * x1 + x0))
                f.dev_h.append(abs(y - 2 * y1 + y0))
                f.n_dev += 1
                if f.n_dev >= _JITTER_SAMPLES and f.n_dev % 10 == 0:
                    # white noise: the second difference has sqrt(6) sigma; sigma = 1.4826 x MAD
                    f.sigma_z = _MAD_SIGMA * _median(f.dev_z)
                    f.sigma_h = _MAD_SIGMA * _median(f.dev_h)
            med = (
                [sorted(r[i] for r in f.raw)[len(f.raw) // 2] for i in range(3)]
                if len(f.raw) == 3
                else [x, y, z]
            )
            a = 1.0 - (1.0 - c.smooth_alpha) ** max(dt * c.rate_hz, 1e-3)
            f.pos = [p + a * (q - p) for p, q in zip(f.pos, med, strict=True)]
        f.seen_t = t
        f.hist.append((t, f.pos[0], f.pos[1], f.pos[2]))
        return True

    def _thresholds(self, f: _Foot) -> tuple[float, float]:
        """(up, horizontal) lift-off thresholds of this foot, metres: body-scaled, at least
        ``noise_k`` raw jitters (the smoothed ankle's noise is about half the raw one's, and its
        excursions above 2.2 of its own sigma are rarer than 1e-4 per frame)."""
        c = self.config
        up = max(c.lift_up * self._leg, c.noise_k * f.sigma_z)
        side = max(c.lift_side * self._leg, 1.3 * c.noise_k * f.sigma_h)
        return up, side

    def _lag_s(self) -> float:
        """Delay of the smoothed ankle: one frame for the median of three, (1 - a) / a for the EMA."""
        a = self.config.smooth_alpha
        return (1.0 + (1.0 - a) / a) / self.config.rate_hz

    def _box(self, f: _Foot) -> float:
        """Per-axis range within which a smoothed ankle counts as still, metres."""
        return max(self.config.land_box * self._leg, 2.2 * max(f.sigma_z, f.sigma_h))

    def _departure(self, f: _Foot) -> tuple[float, float]:
        """(up, horizontal) distance of the smoothed ankle from its anchor, metres."""
        assert f.pos is not None and f.anchor is not None
        return f.pos[2] - f.anchor[2], math.hypot(f.pos[0] - f.anchor[0], f.pos[1] - f.anchor[1])

    def _lift(self, k: int, t: float) -> bool:
        """Start a swing if the departure was quick; else the anchor moves (a slow drift). True = lift."""
        c = self.config
        f = self._feet[k]
        assert f.anchor is not None and f.pos is not None
        up_thr, side_thr = self._thresholds(f)
        start = t
        for ht, hx, hy, hz in reversed(f.hist):  # back-date to where the departure began
            near = (
                hz - f.anchor[2] < 0.3 * up_thr
                and math.hypot(hx - f.anchor[0], hy - f.anchor[1]) < 0.3 * side_thr
            )
            if near:
                break
            start = ht
        if t - start > c.max_rise_s:
            f.anchor = list(f.pos)
            return False
        start = max(start - self._lag_s(), f.land_t)  # the smoothed ankle lags the real one
        f.planted = False
        f.lift_t = start
        f.lift_pos = (f.anchor[0], f.anchor[1], f.anchor[2])
        f.lift_yaw = self._yaw if self._yaw is not None else 0.0
        f.lift_axes = body_axes(f.lift_yaw)
        other_at = self._feet[1 - k].anchor
        f.split = (
            (f.anchor[0] - other_at[0]) * f.lift_axes[1][0] + (f.anchor[1] - other_at[1]) * f.lift_axes[1][1]
            if other_at is not None
            else math.nan
        )
        f.turn = 0.0
        f.lateral = f.sagittal = f.vertical = 0.0
        f.far, f.far_pos, f.far_t = 0.0, f.lift_pos, start
        f.kind = "small"
        f.still_since = math.nan
        other = self._feet[1 - k]
        f.jump = (not other.planted) and abs(other.lift_t - start) <= c.jump_sync_s
        if f.jump:
            other.jump = True
        self._stepping = k
        self._last_lift_t = start
        return True

    def _land(self, f: _Foot, t_land: float) -> None:
        assert f.pos is not None
        f.anchor = list(f.pos)  # the foot may still settle: the anchor follows fast for a moment
        f.planted = True
        f.still_since = math.nan
        f.land_t = t_land
        self._last_land_t = t_land

    def _still_window(self, f: _Foot, t: float) -> list[tuple[float, float, float, float]] | None:
        """The last land_window_s of the smoothed ankle if it stayed within the landing box."""
        c = self.config
        box = self._box(f)
        win = [h for h in f.hist if h[0] >= t - c.land_window_s - 1e-9]
        if len(win) < 2 or win[0][0] > t - c.land_window_s + 0.5 / c.rate_hz:
            return None
        for i in (1, 2, 3):
            vals = [w[i] for w in win]
            if max(vals) - min(vals) > box:
                return None
        return win

    def _land_fast(self, f: _Foot, t: float) -> None:
        """A short stance (running, a quick tap): the raw foot point of the last three frames stayed
        within ``raw_land_k`` of its jitter on every axis, near the standing level. The smoothed
        ankle is still moving then, so it is set to where the foot stands."""
        c = self.config
        if len(f.raw) < 3 or f.floor is None:
            return
        box_z = max(c.land_box * self._leg, c.raw_land_k * f.sigma_z)
        box_h = max(c.land_box * self._leg, c.raw_land_k * f.sigma_h)
        for i, box in ((0, box_h), (1, box_h), (2, box_z)):
            vals = [r[i] for r in f.raw]
            if max(vals) - min(vals) > box:
                return
        mid = [sorted(r[i] for r in f.raw)[1] for i in range(3)]
        if mid[2] - f.floor >= max(c.land_height * self._leg, 0.5 * self._thresholds(f)[0]):
            return
        f.pos = mid
        f.hist.append((t, mid[0], mid[1], mid[2]))
        self._land(f, max(t - 2.0 / c.rate_hz, f.lift_t + c.min_swing_s))

    def _first_was_outlier(self, f: _Foot) -> bool:
        """The ankle's first point lies off the next two, which agree with each other (within the
        lift-off thresholds): an outlier, not a foot already moving when it was first seen."""
        if len(f.first_points) < 3:
            return False
        up_thr, side_thr = self._thresholds(f)
        (x0, y0, z0, _), (x1, y1, z1, _), (x2, y2, z2, _) = f.first_points
        return (
            abs(z1 - z2) < up_thr
            and math.hypot(x1 - x2, y1 - y2) < side_thr
            and (abs(z0 - z1) >= up_thr or math.hypot(x0 - x1, y0 - y1) >= side_thr)
        )

    def _update_foot(self, k: int, t: float, dt: float) -> None:
        c = self.config
        f = self._feet[k]
        assert f.pos is not None
        if f.anchor is None:
            f.anchor = list(f.pos)
            f.floor = f.pos[2]
            f.first_checked = False
            return
        if not f.first_checked and len(f.raw) == 3:
            # no lift-off before the median of three runs (below: a lone outlier passes the first
            # frames' smoothing); then, if the first point was one, it is not the anchor: the foot
            # would look lifted until the anchor caught up (a step nobody made)
            f.first_checked = True
            if self._first_was_outlier(f):
                # the three points again, with the knee-ankle baseline as it is now
                base = f.shank
                f.raw.clear()
                for x, y, z, shank in f.first_points:
                    fix = 0.5 * (shank - base) if base is not None and math.isfinite(shank) else 0.0
                    f.raw.append((x, y, z + fix))
                f.pos = [sorted(r[i] for r in f.raw)[1] for i in range(3)]
                f.anchor, f.floor = list(f.pos), f.pos[2]
                f.hist.clear()
                f.hist.append((t, f.pos[0], f.pos[1], f.pos[2]))
                return
        just_lifted = False
        if f.planted:
            up, horiz = self._departure(f)
            up_thr, side_thr = self._thresholds(f)
            just_lifted = self.config.defer_landing and f.n_dev >= _JITTER_SAMPLES  # its jitter is measured
            if not ((up > up_thr or horiz > side_thr) and f.first_checked and self._lift(k, t)):
                settling = t - f.land_t < 0.25
                w = self._w(0.08 if settling else c.anchor_tau_s, dt)
                f.anchor = [a + w * (p - a) for a, p in zip(f.anchor, f.pos, strict=True)]
                assert f.floor is not None
                if f.anchor[2] < f.floor:
                    f.floor = f.anchor[2]
                else:
                    f.floor += self._w(c.floor_tau_s, dt) * (f.anchor[2] - f.floor)
                return
        # swinging
        f.lateral, f.sagittal = _from_lift(f, f.pos)
        f.vertical = max(f.vertical, f.pos[2] - f.lift_pos[2])
        if self._yaw is not None:
            f.turn = (self._yaw - f.lift_yaw + math.pi) % (2 * math.pi) - math.pi
        f.kind = step_kind(k, f.lateral, f.sagittal, f.vertical, self._leg, c)
        if just_lifted or t - f.lift_t < c.min_swing_s:
            return  # a step lands at the earliest in the next frame (its lift-off is seen first)
        if c.turn_split and self._turned_back(k, f, t):
            return
        if t - f.lift_t > c.max_swing_s:
            self._land(f, t)
            return
        win = self._still_window(f, t)
        if win is None:
            f.still_since = math.nan
            self._land_fast(f, t)
            return
        if math.isnan(f.still_since):
            f.still_since = win[0][0]
        assert f.floor is not None
        low = f.pos[2] - f.floor < max(c.land_height * self._leg, 0.5 * self._thresholds(f)[0])
        if low or t - f.still_since >= c.hold_s:
            self._land(f, max(f.still_since - 0.5 * self._lag_s(), f.lift_t + c.min_swing_s))

    def _turned_back(self, k: int, f: _Foot, t: float) -> bool:
        """Land a swing at its farthest point if it went inwards, touched down there and is going
        back out (see ``StepConfig.turn_far``); the foot lifts off again from there in a later
        frame. True = landed."""
        assert f.pos is not None and f.floor is not None
        dist = math.hypot(f.pos[0] - f.lift_pos[0], f.pos[1] - f.lift_pos[1])
        if dist > f.far:
            f.far, f.far_pos, f.far_t = dist, (f.pos[0], f.pos[1], f.pos[2]), t
            return False
        up_thr, side_thr = self._thresholds(f)
        lateral, sagittal = _from_lift(f, f.far_pos)
        if not (
            f.far >= self.config.turn_far * self._leg
            and abs(lateral) >= 1.2 * abs(sagittal)  # sideways (a walk's or a kick's swing is not)
            and (lateral if k == 0 else -lateral) > 0  # inwards, then out (a dance's tap: out, back)
            and f.far - dist >= side_thr
            and f.far_pos[2] - f.floor < max(up_thr, self.config.turn_low * self._leg)
            and f.far_t - f.lift_t >= self.config.min_swing_s
        ):
            return False
        # the step in as it was at its farthest point: its displacement and kind
        f.lateral, f.sagittal = lateral, sagittal
        f.kind = step_kind(k, f.lateral, f.sagittal, f.vertical, self._leg, self.config)
        self._land(f, f.far_t)
        f.anchor = list(f.far_pos)  # the next lift-off starts where it touched down
        return True

    def _update_pelvis(self, j: _Rows, dt: float) -> None:
        c = self.config
        hips = [j[i][2] for i in _HIP if math.isfinite(j[i][2])]
        floors = [f.floor for f in self._feet if f.floor is not None]
        if not hips or not floors:
            return
        h = sum(hips) / len(hips) - min(floors)
        if self._standing is None:
            self._standing = h
        elif self._feet[0].planted and self._feet[1].planted:
            if h > self._standing:
                self._standing += 0.2 * (h - self._standing)
            else:
                self._standing += self._w(c.standing_tau_s, dt) * (h - self._standing)
        self._pelvis_ratio = h / self._standing if self._standing > 0.2 * self._leg else 1.0

    def _update_tilt(self, j: _Rows) -> None:
        """Trunk tilt from vertical (degrees), smoothed; held while hips or shoulders are unknown."""
        (lh, rh), (ls, rs) = (j[i] for i in _HIP), (j[i] for i in _SHOULDER)
        if not all(math.isfinite(v) for row in (lh, rh, ls, rs) for v in row):
            return
        # the shoulders' mean minus the hips' (numpy's arithmetic, in plain floats)
        dx, dy, dz = ((ls[i] + rs[i]) / 2.0 - (lh[i] + rh[i]) / 2.0 for i in range(3))
        norm = math.sqrt(dx * dx + dy * dy + dz * dz)
        if norm < 1e-6:
            return
        tilt = math.degrees(math.acos(max(-1.0, min(1.0, dz / norm))))
        self._tilt += self.config.yaw_alpha * (tilt - self._tilt)

    def _raise_deg(self, j: _Rows, k: int) -> float:
        """How far leg ``k`` is raised from straight down, forward or sideways (degrees; NaN unknown)."""
        ax, ay, az = j[_ANKLE[k]]
        hx, hy, hz = j[_HIP[k]]
        dx, dy, dz = ax - hx, ay - hy, az - hz
        if self._yaw is None or not (math.isfinite(dx) and math.isfinite(dy) and math.isfinite(dz)):
            return math.nan
        (rx, ry), (fx, fy) = body_axes(self._yaw)
        forward = max(dx * fx + dy * fy, 0.0)  # a leg behind the hip: only its side
        return math.degrees(math.atan2(math.hypot(forward, dx * rx + dy * ry), -dz))

    # -- the frame

    def update(self, joints_m: NDArray[np.floating], timestamp_s: float) -> StepFrame:
        """Add one skeleton (17, 3) metres, NaN unknown; timestamps must increase."""
        c = self.config
        j = np.asarray(joints_m, dtype=np.float64)
        if j.shape != (NUM_JOINTS, 3):
            raise ValueError(f"joints must have shape ({NUM_JOINTS}, 3), got {j.shape}")
        t = float(timestamp_s)
        if self._t is not None and t <= self._t:
            raise ValueError(f"timestamps must increase: got {t} after {self._t}")
        dt = 1.0 / c.rate_hz if self._t is None else t - self._t
        self._t = t
        rows: _Rows = j.tolist()  # plain floats: reading a numpy element costs more than its arithmetic
        self._update_scale(rows)
        self._update_yaw(rows)
        events: list[tuple[bool, bool, float]] = []
        for k in (0, 1):
            f = self._feet[k]
            was_planted = f.planted
            if self._smooth(f, self._foot_point(f, rows[_ANKLE[k]], rows[_KNEE[k]], dt), t, dt):
                self._update_foot(k, t, dt)
            lifted = was_planted and not f.planted
            landed = (not was_planted) and f.planted
            events.append((lifted, landed, f.lift_t if lifted else (f.land_t if landed else math.nan)))
        self._update_pelvis(rows, dt)
        self._update_tilt(rows)
        raised = [self._raise_deg(rows, k) for k in (0, 1)]
        feet = []
        for k in (0, 1):
            f = self._feet[k]
            known = f.pos is not None and t - f.seen_t <= c.lost_s
            height = f.pos[2] - f.floor if (f.pos is not None and f.floor is not None) else math.nan
            lifted, landed, ev_t = events[k]
            rising = False
            if f.planted and f.pos is not None and f.anchor is not None:
                up, horiz = self._departure(f)
                up_thr, side_thr = self._thresholds(f)
                rising = up > 0.5 * up_thr or horiz > 0.5 * side_thr
            feet.append(
                FootState(
                    known=known,
                    planted=f.planted,
                    rising=rising,
                    lifted=lifted,
                    landed=landed,
                    event_t=ev_t,
                    height_m=height,
                    swing_s=0.0 if f.planted else t - f.lift_t,
                    lateral_m=f.lateral,
                    sagittal_m=f.sagittal,
                    vertical_m=f.vertical,
                    kind=f.kind,
                    jump=f.jump,
                    turn_deg=math.degrees(f.turn),
                    raise_deg=raised[k],
                    split_m=f.split,
                )
            )
        return StepFrame(
            t=t,
            feet=(feet[0], feet[1]),
            leg_m=self._leg,
            crouched=self._pelvis_ratio < c.crouch_ratio and not self._straight >= c.crouch_straight,
            pelvis_ratio=self._pelvis_ratio,
            stepping=self._stepping,
            last_lift_t=self._last_lift_t,
            last_land_t=self._last_land_t,
            upright=self._tilt <= c.max_tilt_deg,
            tilt_deg=self._tilt,
            yaw_deg=math.degrees(self._yaw) if self._yaw is not None else math.nan,
        )


# ---------------------------------------------------------------- whole sequences


@dataclass(frozen=True, slots=True)
class StepEvidence:
    """The evidence of a whole sequence (T frames).

    planted: (T, 2) bool contact per foot [left, right]; known: (T, 2) bool.
    height_m, lateral_m, sagittal_m, vertical_m, swing_s: (T, 2) float.
    kind: (T, 2) int index into KINDS; jump: (T, 2) bool; crouched: (T,) bool; pelvis_ratio: (T,).
    lifts / lands: (N, 2) arrays of [time_s, foot] of each lift-off / touch-down (back-dated).
    leg_m: (T,) body scale.
    """

    planted: NDArray[np.bool_]
    known: NDArray[np.bool_]
    height_m: NDArray[np.float64]
    lateral_m: NDArray[np.float64]
    sagittal_m: NDArray[np.float64]
    vertical_m: NDArray[np.float64]
    swing_s: NDArray[np.float64]
    kind: NDArray[np.int64]
    jump: NDArray[np.bool_]
    crouched: NDArray[np.bool_]
    pelvis_ratio: NDArray[np.float64]
    lifts: NDArray[np.float64]
    lands: NDArray[np.float64]
    leg_m: NDArray[np.float64]


def evidence_from_frames(frames: list[StepFrame]) -> StepEvidence:
    """Stack per-frame evidence into arrays."""

    def feet(attr: str, dtype: type) -> NDArray:  # type: ignore[type-arg]
        return np.array([[getattr(f, attr) for f in fr.feet] for fr in frames], dtype=dtype).reshape(-1, 2)

    lifts = [(fr.feet[k].event_t, k) for fr in frames for k in (0, 1) if fr.feet[k].lifted]
    lands = [(fr.feet[k].event_t, k) for fr in frames for k in (0, 1) if fr.feet[k].landed]
    return StepEvidence(
        planted=feet("planted", bool),
        known=feet("known", bool),
        height_m=feet("height_m", float),
        lateral_m=feet("lateral_m", float),
        sagittal_m=feet("sagittal_m", float),
        vertical_m=feet("vertical_m", float),
        swing_s=feet("swing_s", float),
        kind=np.array([[KINDS.index(f.kind) for f in fr.feet] for fr in frames], dtype=np.int64).reshape(
            -1, 2
        ),
        jump=feet("jump", bool),
        crouched=np.array([fr.crouched for fr in frames], dtype=bool),
        pelvis_ratio=np.array([fr.pelvis_ratio for fr in frames], dtype=np.float64),
        lifts=np.array(lifts, dtype=np.float64).reshape(-1, 2),
        lands=np.array(lands, dtype=np.float64).reshape(-1, 2),
        leg_m=np.array([fr.leg_m for fr in frames], dtype=np.float64),
    )


def step_evidence(
    joints_m: NDArray[np.floating], fps: float, config: StepConfig | None = None
) -> StepEvidence:
    """Run :class:`StepTracker` over a whole sequence (T, 17, 3) at ``fps``."""
    arr = np.asarray(joints_m, dtype=np.float64)
    if arr.ndim != 3 or arr.shape[1:] != (NUM_JOINTS, 3):
        raise ValueError(f"joints must have shape (T, {NUM_JOINTS}, 3), got {arr.shape}")
    if not math.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps must be positive, got {fps}")
    tracker = StepTracker(config)
    arr = np.where(np.isfinite(arr), arr, np.nan)
    return evidence_from_frames([tracker.update(f, i / fps) for i, f in enumerate(arr)])
