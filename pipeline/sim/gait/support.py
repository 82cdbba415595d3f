"""From joint angles and a foot-contact programme to joint positions in the world.

The body has no root trajectory of its own: it is carried by its feet. Each foot in
contact is pinned to the floor at its pivot (the heel while the foot is pitched toe-up,
the ball while it is pitched toe-down, so a foot rolls heel-to-toe without sliding), and
the pelvis is placed so that the supporting leg's forward kinematics reach that pin. In
double support the pelvis moves from the leg it came from to the leg that will carry it
next (a smooth weight ramp); both legs then reach their pins with a two-bone IK. Where the
pins lie beyond the legs' reach the pelvis is lowered, smoothly, just enough (the knees
bend). With no foot on the floor (running, a jump) the pelvis flies ballistically from
take-off to the landing the angles give. A swinging foot follows its angles; near lift-off
and touch-down it is blended onto where it left and where it lands, and kept above the
floor. A foot marked as sliding keeps its contact but follows its angles along the floor.

So a stance foot never slides, every bone keeps its length, a planted foot's sole is on
the floor, and the body travels exactly as far as its leg angles carry it over its feet.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.gait.anthropometry import Body
from pipeline.sim.gait.kinematics import NCH, Ch, RelativePose, forward, rot_z, two_bone_ik
from pipeline.skeleton import J

F64 = NDArray[np.float64]
GRAVITY = 9.81
REACH = 0.999  # share of the full leg length a solved leg may stretch to


@dataclass(frozen=True, slots=True)
class Programme:
    """What a body does, frame by frame.

    angles: (T, NCH) pose channels (radians, :class:`~pipeline.sim.gait.kinematics.Ch`).
    contact: (T, 2) bool, foot [left, right] on the floor.
    slide: (T, 2) bool, a foot in contact that slides along the floor (a shuffle).
    home: (T, 2) bool, set on a foot's airborne frames when that step lands back on the
    footprint it left (stepping in place) rather than where its angles carry it.
    labels / tags: (T,) per-frame action label and behaviour tag (TEAM.md LABELS).
    """

    angles: F64
    contact: NDArray[np.bool_]
    slide: NDArray[np.bool_]
    home: NDArray[np.bool_]
    labels: tuple[str, ...]
    tags: tuple[str, ...]

    def __post_init__(self) -> None:
        t = self.angles.shape[0]
        if self.angles.shape != (t, NCH):
            raise ValueError(f"angles must have shape (T, {NCH}), got {self.angles.shape}")
        for name in ("contact", "slide", "home"):
            arr = getattr(self, name)
            if arr.shape != (t, 2) or arr.dtype != np.bool_:
                raise ValueError(f"{name} must be bool (T, 2) = ({t}, 2), got {arr.dtype} {arr.shape}")
        if np.any(self.slide & ~self.contact):
            raise ValueError("a sliding foot must be in contact")
        if len(self.labels) != t or len(self.tags) != t:
            raise ValueError(f"labels and tags need {t} entries, got {len(self.labels)} and {len(self.tags)}")

    def __len__(self) -> int:
        return int(self.angles.shape[0])


@dataclass(frozen=True, slots=True)
class Solved:
    """World positions of a programme (metres, CAVE frame).

    joints: (T, 17, 3) COCO joints; heel, ball: (T, 2, 3) the soles' points;
    pin: (T, 2, 3) the floor point a supporting foot is pinned to (NaN when not pinned);
    pelvis: (T, 3) the mid-hip point.
    """

    joints: F64
    heel: F64
    ball: F64
    pin: F64
    pelvis: F64


def _smooth(s: F64) -> F64:
    s = np.clip(s, 0.0, 1.0)
    return s * s * (3 - 2 * s)


def support_weight(support: NDArray[np.bool_]) -> F64:
    """The right foot's share (T,) in placing the pelvis: 0 on the left foot alone, 1 on the right."""
    t_len = support.shape[0]
    w = np.full(t_len, 0.5)
    t = 0
    while t < t_len:
        both = support[t].all()
        if not both:
            if support[t, 0]:
                w[t] = 0.0
            elif support[t, 1]:
                w[t] = 1.0
            else:
                w[t] = w[t - 1] if t > 0 else 0.5
            t += 1
            continue
        end = t
        while end < t_len and support[end].all():
            end += 1
        start_w = w[t - 1] if t > 0 else 0.5
        if end < t_len and support[end, 0] != support[end, 1]:
            target = 1.0 if support[end, 1] else 0.0
        else:
            target = start_w
        n = end - t
        s = _smooth((np.arange(n) + 1) / (n + 1))
        w[t:end] = start_w + (target - start_w) * s
        t = end
    return w


def _pivots(rel: RelativePose) -> tuple[NDArray[np.bool_], F64]:
    on_heel = rel.foot_pitch >= 0.0
    return on_heel, np.where(on_heel[..., None], rel.heel, rel.ball)


def _place_pelvis(
    rel: RelativePose, prog: Programme, fps: float, start_xy: tuple[float, float]
) -> tuple[F64, F64]:
    """Pelvis (T, 3) and pins (T, 2, 3) by walking through the frames."""
    t_len = len(prog)
    on_heel, pivot = _pivots(rel)
    support = prog.contact & ~prog.slide
    w = support_weight(support)
    pelvis = np.zeros((t_len, 3))
    pins = np.full((t_len, 2, 3), np.nan)
    if not support[0].any():
        raise ValueError("a programme must start with a foot on the floor")
    pin: list[F64 | None] = [None, None]
    flat_pin: list[F64 | None] = [None, None]  # the last heel pin of each foot (its footprint)
    heel_kind: list[bool] = [True, True]
    t = 0
    while t < t_len:
        if not prog.contact[t].any():
            end = t
            while end < t_len and not prog.contact[end].any():
                end += 1
            _fly(pelvis, pivot, prog, t, end, fps)
            pin = [None, None]
            t = end
            continue
        existing = [s for s in (0, 1) if prog.contact[t, s] and pin[s] is not None]
        for s in existing:
            p = pin[s]
            if p is not None and not prog.slide[t, s] and heel_kind[s] != on_heel[t, s]:
                # The foot rolls over onto its other end: pin that end where it lay when the
                # foot was flattest (this frame or the one before).
                old, new = (rel.heel, rel.ball) if heel_kind[s] else (rel.ball, rel.heel)
                k = t if abs(rel.foot_pitch[t, s]) <= abs(rel.foot_pitch[t - 1, s]) else t - 1
                moved = p + new[k, s] - old[k, s]
                moved[2] = 0.0
                pin[s] = moved
                heel_kind[s] = bool(on_heel[t, s])
        carrying = [s for s in existing if support[t, s]]
        if carrying:
            share = np.array([1.0 - w[t], w[t]])[carrying]
            share = share / share.sum() if share.sum() > 0 else np.full(len(carrying), 1 / len(carrying))
            pelvis[t] = sum(
                share[i] * (pin[s] - pivot[t, s]) for i, s in enumerate(carrying)  # type: ignore[operator]
            )
        elif t == 0:
            down = [s for s in (0, 1) if prog.contact[0, s]]
            pelvis[0] = (start_xy[0], start_xy[1], -float(np.mean(pivot[0, down, 2])))
        elif not any(pin[s] is not None for s in (0, 1)) and t > 0 and not prog.contact[t - 1].any():
            pass  # landing frame: _fly already placed the pelvis
        else:
            pelvis[t] = pelvis[t - 1]
        for s in (0, 1):
            if not prog.contact[t, s]:
                pin[s] = None
            elif pin[s] is None or prog.slide[t, s]:
                heel_kind[s] = bool(on_heel[t, s])
                home = flat_pin[s]
                if pin[s] is None and t > 0 and prog.home[t - 1, s] and home is not None:
                    p = home.copy()
                    if not heel_kind[s]:  # landing on the ball: the heel will come down on the footprint
                        sole = rel.ball[t, s, :2] - rel.heel[t, s, :2]
                        length = np.linalg.norm(rel.ball[t, s] - rel.heel[t, s])
                        p[:2] += sole / max(float(np.linalg.norm(sole)), 1e-9) * length
                else:
                    p = pelvis[t] + pivot[t, s]
                    p[2] = 0.0
                pin[s] = p
            if pin[s] is not None and heel_kind[s] and not prog.slide[t, s]:
                flat_pin[s] = pin[s]
            pins[t, s] = pin[s]  # type: ignore[assignment]
        t += 1
    return pelvis, pins


def _fly(pelvis: F64, pivot: F64, prog: Programme, start: int, end: int, fps: float) -> None:
    """Ballistic pelvis over the flight frames [start, end) and the landing frame ``end``."""
    t_len = pelvis.shape[0]
    p0 = pelvis[start - 1]
    v = (pelvis[start - 1] - pelvis[start - 2]) * fps if start >= 2 else np.zeros(3)
    steps = np.arange(start, min(end, t_len - 1) + 1)
    tau = (steps - (start - 1)) / fps
    xy = p0[:2] + v[:2] * tau[:, None]
    if end < t_len:
        down = [s for s in (0, 1) if prog.contact[end, s]]
        z_end = -float(np.mean(pivot[end, down, 2]))
        flight = (end - start + 1) / fps
        vz = (z_end - p0[2] + GRAVITY * flight**2 / 2) / flight
    else:
        vz = v[2]
    z = p0[2] + vz * tau - GRAVITY * tau**2 / 2
    pelvis[steps, :2] = xy
    pelvis[steps, 2] = z


def _ankle_targets_in_contact(rel: RelativePose, pins: F64) -> F64:
    """Where each pinned foot's ankle is: its pivot on the pin, its pitch as the angles say."""
    _, pivot = _pivots(rel)
    return pins - (pivot - rel.ankle)


def _lower_to_reach(body: Body, rel: RelativePose, pelvis: F64, targets: F64, fps: float) -> F64:
    """Pelvis heights lowered (smoothly) where a planted foot is out of its leg's reach."""
    reach = REACH * body.leg_m
    hip = pelvis[:, None, :] + rel.hip
    dxy2 = np.sum((hip[..., :2] - targets[..., :2]) ** 2, axis=-1)
    with np.errstate(invalid="ignore"):
        z_max = targets[..., 2] + np.sqrt(np.maximum(reach**2 - dxy2, 0.0)) - rel.hip[..., 2]
    drop = np.where(np.isfinite(z_max), np.minimum(0.0, z_max - pelvis[:, None, 2]), 0.0).min(axis=1)
    width = max(1, round(0.15 * fps))
    smooth = drop.copy()
    for k in range(1, width + 1):
        weight = np.cos(np.pi * k / (2 * (width + 1))) ** 2
        smooth[k:] = np.minimum(smooth[k:], drop[:-k] * weight)
        smooth[:-k] = np.minimum(smooth[:-k], drop[k:] * weight)
    out = pelvis.copy()
    out[:, 2] += smooth
    return out


def _swing_targets(body: Body, rel: RelativePose, pelvis: F64, prog: Programme, stance: F64) -> F64:
    """Ankle targets (T, 2, 3) of every foot: pinned in contact, blended in the air."""
    t_len = len(prog)
    targets = stance.copy()
    for s in (0, 1):
        air = ~prog.contact[:, s]
        fk = pelvis + rel.ankle[:, s]
        sole = np.minimum((rel.heel[:, s] - rel.ankle[:, s])[:, 2], (rel.ball[:, s] - rel.ankle[:, s])[:, 2])
        t = 0
        while t < t_len:
            if not air[t]:
                t += 1
                continue
            end = t
            while end < t_len and air[end]:
                end += 1
            d0 = stance[t - 1, s] - fk[t - 1] if t > 0 else np.zeros(3)
            d1 = stance[end, s] - fk[end] if end < t_len else np.zeros(3)
            k = np.arange(t, end)
            frac = (k - t + 1) / (end - t + 1)
            a0 = 1.0 - _smooth(frac / 0.45)
            a1 = _smooth((frac - 0.55) / 0.45) if end < t_len else np.zeros(len(k))
            tgt = fk[k] + a0[:, None] * d0 + a1[:, None] * d1
            tgt[:, 2] = np.maximum(tgt[:, 2], -sole[k])
            targets[k, s] = tgt
            t = end
    return targets


def solve(body: Body, prog: Programme, fps: float, start_xy: tuple[float, float] = (0.0, 0.0)) -> Solved:
    """World joints for a programme, the body starting with its pelvis above ``start_xy``."""
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be positive, got {fps}")
    rel = forward(body, prog.angles)
    pelvis, pins = _place_pelvis(rel, prog, fps, start_xy)
    stance = _ankle_targets_in_contact(rel, pins)
    pelvis = _lower_to_reach(body, rel, pelvis, stance, fps)
    targets = _swing_targets(body, rel, pelvis, prog, stance)
    joints = pelvis[:, None, :] + rel.upper
    heel = np.empty_like(rel.heel)
    ball = np.empty_like(rel.ball)
    for s, name in ((0, "l"), (1, "r")):
        hip = pelvis + rel.hip[:, s]
        forward_dir = np.einsum("tij,j->ti", rot_z(prog.angles[:, Ch.YAW]), np.array([0.0, 1.0, 0.0]))
        bend = rel.knee[:, s] - rel.hip[:, s]
        knee, ankle = two_bone_ik(hip, targets[:, s], bend + 0.02 * forward_dir, body.thigh_m, body.shank_m)
        joints[:, J[f"{name}_knee"]] = knee
        joints[:, J[f"{name}_ankle"]] = ankle
        heel[:, s] = ankle + rel.heel[:, s] - rel.ankle[:, s]
        ball[:, s] = ankle + rel.ball[:, s] - rel.ankle[:, s]
    pinned = np.where((prog.contact & ~prog.slide)[..., None], pins, np.nan)
    return Solved(joints, heel, ball, pinned, pelvis)
