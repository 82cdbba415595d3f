"""Animated users: 17 COCO joints in 3D in the CAVE frame, with ground-truth labels, tags and contacts.

:func:`simulate_user` plays a :class:`MotionScript` with a :class:`BodyParams` body and a
personal :class:`MotionStyle`. Each segment is planned by its behaviour
(:mod:`pipeline.sim.stepping`: marching, walking, running, side steps, turns on the spot;
:mod:`pipeline.sim.behaviours`: the still library, crouching to stretching;
:mod:`pipeline.sim.idle`: standing idle and gestures), as foot moves on the floor
(:mod:`pipeline.sim.feet`) and per-frame control channels (:mod:`pipeline.sim.plan`). The body
is then posed on its feet: the pelvis follows the feet's midpoint (smoothed: it shifts before
a step), moves over the stance foot during a step and is lowered where a leg could not reach
its foot; knees and elbows by two-bone IK, so bone lengths never change and a planted foot
never slides.

Labels (TEAM.md LABELS): a stepping segment is one bout, its first lift-off at the segment's
start and its last touch-down at its end, so the label switches exactly at segment boundaries
and pauses inside a bout keep the bout's label. ``turn`` and every still behaviour are
``still``. Tags name the behaviour (``march``, ``step-together``, ``turn``, a gesture ...).
Contacts are True while a foot is planted (it may swivel or glide while bearing weight) and
False during a step's lift or slide and a jump's flight. Speed is the *intended* virtual speed:
0 when still, cadence x step length when stepping in place, the travel speed when walking.
Everything random comes from ``seed``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.sim.behaviours import plan_behaviour
from pipeline.sim.body import (
    FACE_OFFSETS_M,
    BodyParams,
    MotionStyle,
    apply,
    arm_reach,
    body_from_height,
    rot_x,
    rot_y,
    rot_z,
    sample_body,
    sample_style,
    two_bone_ik,
)
from pipeline.sim.feet import LEFT, RIGHT, SIDE_SIGN, Feet, FeetTrack, right_xy
from pipeline.sim.idle import idle_layer, schedule_gestures, tag_gestures
from pipeline.sim.plan import ArmPose, Channels, Ctx
from pipeline.sim.script import (
    GESTURES,
    MotionScript,
    Segment,
    load_script,
    random_script,
    save_script,
    script_from_dict,
)
from pipeline.sim.signals import smooth, smoothstep, wrap_deg
from pipeline.sim.stepping import pivot_turn, plan_bout, resolve_bout
from pipeline.skeleton import ACTIONS, NUM_JOINTS, J, SkeletonSequence

__all__ = [
    "GESTURES",
    "STEP_LENGTH_M",
    "BodyParams",
    "MotionScript",
    "MotionStyle",
    "Segment",
    "UserMotion",
    "body_from_height",
    "load_script",
    "random_script",
    "sample_body",
    "sample_style",
    "save_script",
    "script_from_dict",
    "simulate_user",
    "smoothstep",
    "wrap_deg",
]

F64 = NDArray[np.float64]

SOURCE = "sim"
# Virtual distance covered per recognised step (intended speed = cadence x this).
STEP_LENGTH_M: dict[str, float] = {"forward": 0.4, "left": 0.3, "right": 0.3}
STEPPING = ("forward", "left", "right")
CLASP_BLEND_S = 0.6
REACH_MARGIN = 0.995  # legs never straighten beyond this fraction of their length


@dataclass(frozen=True, slots=True)
class UserMotion:
    """One simulated user over time.

    joints_m: (T, 17, 3) float64, COCO joints in the CAVE frame, metres.
    labels: (T,) ground-truth actions from ``ACTIONS``.
    yaw_deg: (T,) facing direction, 0 = +Y, counter-clockwise positive, in (-180, 180].
    speed_mps: (T,) intended speed, 0 when still.
    fps: frames per second.
    root_xy_m: (T, 2) floor position the body stands on (between the feet, smoothed).
    tags: (T,) behaviour names ("" where nothing special).
    contacts: (T, 2) bool, foot planted [left, right].
    """

    joints_m: F64
    labels: tuple[str, ...]
    yaw_deg: F64
    speed_mps: F64
    fps: float
    root_xy_m: F64
    tags: tuple[str, ...]
    contacts: NDArray[np.bool_]

    def __post_init__(self) -> None:
        j = np.asarray(self.joints_m, dtype=np.float64)
        if j.ndim != 3 or j.shape[1:] != (NUM_JOINTS, 3):
            raise ValueError(f"joints_m must be (T, 17, 3), got {j.shape}")
        n = j.shape[0]
        for name in ("yaw_deg", "speed_mps"):
            arr = np.asarray(getattr(self, name), dtype=np.float64)
            if arr.shape != (n,):
                raise ValueError(f"{name} must be ({n},), got {arr.shape}")
            object.__setattr__(self, name, arr)
        root = np.asarray(self.root_xy_m, dtype=np.float64)
        if root.shape != (n, 2):
            raise ValueError(f"root_xy_m must be ({n}, 2), got {root.shape}")
        if len(self.labels) != n or any(lb not in ACTIONS for lb in self.labels):
            raise ValueError(f"labels must be {n} entries from {ACTIONS}")
        if len(self.tags) != n:
            raise ValueError(f"tags must have {n} entries, got {len(self.tags)}")
        contacts = np.asarray(self.contacts, dtype=bool)
        if contacts.shape != (n, 2):
            raise ValueError(f"contacts must be ({n}, 2), got {contacts.shape}")
        object.__setattr__(self, "joints_m", j)
        object.__setattr__(self, "root_xy_m", root)
        object.__setattr__(self, "labels", tuple(self.labels))
        object.__setattr__(self, "tags", tuple(self.tags))
        object.__setattr__(self, "contacts", contacts)

    def __len__(self) -> int:
        return int(self.joints_m.shape[0])

    def to_sequence(self) -> SkeletonSequence:
        """The SPEC skeleton sequence: joints, fps, labels, tags, contacts, ``source="sim"``."""
        return SkeletonSequence(self.joints_m, self.fps, self.labels, self.tags, self.contacts, SOURCE)


def _yaw_channel(script: MotionScript, t: F64, starts: F64, dur: F64, k: NDArray[np.int64]) -> F64:
    turn = np.array([s.yaw_change_deg for s in script.segments])
    yaw_start = script.start_yaw_deg + np.concatenate([[0.0], np.cumsum(turn)[:-1]])
    frac = np.clip((t - starts[k]) / dur[k], 0.0, 1.0)
    out: F64 = np.radians(yaw_start[k] + turn[k] * smoothstep(frac))
    return out


def simulate_user(
    script: MotionScript,
    body: BodyParams,
    fps: float = 30.0,
    seed: int = 0,
    style: MotionStyle | None = None,
    start_feet_xy_m: tuple[F64, F64] | None = None,
) -> UserMotion:
    """Animate ``body`` through ``script`` at ``fps``; ``style`` None = drawn from ``seed``.

    start_feet_xy_m: where the (left, right) ankles stand on the floor at the start (a routine
    that continues another one); None = side by side around the script's start position.
    """
    if not isinstance(script, MotionScript):
        raise InputError(f"script must be a MotionScript, got {type(script).__name__}")
    if not np.isfinite(fps) or not 1.0 <= fps <= 1000.0:
        raise InputError(f"fps must be in [1, 1000], got {fps}")
    r_style, r_seg, r_noise, r_evt = (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(4))
    style = style if style is not None else sample_style(r_style)
    segs = script.segments
    n_frames = max(1, round(script.duration_s * fps))
    t = np.arange(n_frames) / fps
    dur = np.array([s.duration_s for s in segs])
    ends = np.cumsum(dur)
    starts = ends - dur
    k = np.minimum(np.searchsorted(ends, t + 1e-9, side="right"), len(segs) - 1)
    labels = tuple(segs[i].label for i in k.tolist())

    ch = Channels.zeros(t, _yaw_channel(script, t, starts, dur, k))
    yaw0 = math.radians(script.start_yaw_deg)
    centre = np.asarray(script.start_xy_m, dtype=np.float64)
    half = style.stance_width_m / 2.0 * right_xy(yaw0)
    toe = math.radians(style.toe_out_deg)
    ankles = (centre - half, centre + half)
    if start_feet_xy_m is not None:
        ankles = (
            np.asarray(start_feet_xy_m[0], dtype=np.float64),
            np.asarray(start_feet_xy_m[1], dtype=np.float64),
        )
        if any(a.shape != (2,) or not np.all(np.isfinite(a)) for a in ankles):
            raise InputError(f"start_feet_xy_m must be two finite (x, y) positions, got {start_feet_xy_m}")
        centre = 0.5 * (ankles[0] + ankles[1])
    feet = Feet(ankles, (yaw0 + toe, yaw0 - toe))
    ctx = Ctx(r_seg, body, style, feet, ch, centre, style.stance_width_m)

    cadence = np.zeros(len(segs))
    gestures = []
    for i, (seg, s0) in enumerate(zip(segs, starts.tolist(), strict=True)):
        s1 = s0 + seg.duration_s
        if seg.action != "still" or seg.behaviour not in (None, "idle"):  # re-centre on the feet
            ctx.stance_xy = 0.5 * (ctx.feet.xy[LEFT] + ctx.feet.xy[RIGHT])
        if seg.action in STEPPING:
            cadence[i] = plan_bout(ctx, resolve_bout(seg, s0, s1, style, r_seg))
            continue
        if seg.action == "turn" or seg.yaw_change_deg != 0.0:
            ch.weight_shift[ch.span(s0, s1)] = 0.3
            pivot_turn(ctx, s0, s1)
            ch.tag(s0, s1, "turn")
        if seg.action == "still":
            ch.still[ch.span(s0, s1)] = 1.0
            if seg.behaviour not in (None, "idle"):
                ch.tag(s0, s1, seg.behaviour_name)
                plan_behaviour(ctx, seg, s0, s1)
            gestures += schedule_gestures(r_evt, seg, s0, style.gesture_rate_hz)
    blend = np.array([s.blend_s if s.blend_s is not None else style.blend_s for s in segs])[k]
    ch.still = smooth(ch.still, np.clip(blend, 0.05, 0.5) * fps / 2.0)
    idle_layer(ctx, r_noise, gestures)
    tag_gestures(ctx, gestures)

    track = ctx.feet.render(t)
    joints, support = _pose(body, style, ch, track, fps)

    label_arr = np.array(labels)
    step_len = np.array([STEP_LENGTH_M.get(lb, 0.0) for lb in labels])
    speed = np.where(label_arr == "still", 0.0, step_len * cadence[k])
    travel = np.array([s.travel_mps if s.behaviour_name in ("walk", "run") else 0.0 for s in segs])[k]
    speed = np.where(travel > 0, travel, speed)
    return UserMotion(
        joints_m=joints,
        labels=labels,
        yaw_deg=wrap_deg(np.degrees(ch.yaw)),
        speed_mps=speed,
        fps=float(fps),
        root_xy_m=support,
        tags=tuple(ch.tags),
        contacts=track.contact,
    )


# --- posing the body on its feet ----------------------------------------------------------------


def _pelvis_path(
    body: BodyParams, style: MotionStyle, ch: Channels, track: FeetTrack, fps: float
) -> tuple[F64, F64]:
    """(T, 3) pelvis centre and (T, 2) support point: the feet's smoothed midpoint, the shift over
    the stance foot during steps, the channels' offsets."""
    n = ch.t.shape[0]
    mid = track.base.mean(axis=1)
    feet_centre = smooth(mid, ch.support_sigma_s * fps)
    path = np.where(ch.path_w[:, None] > 0, ch.path_xy, feet_centre)
    w_path = smooth(ch.path_w, 0.1 * fps)[:, None]
    support = (1.0 - w_path) * feet_centre + w_path * path
    right = np.stack([np.cos(ch.yaw), np.sin(ch.yaw)], -1)
    fwd = np.stack([-np.sin(ch.yaw), np.cos(ch.yaw)], -1)
    shift = np.zeros((n, 2))
    for f in (LEFT, RIGHT):
        stance = 1 - f
        single = ~track.contact[:, f] & track.contact[:, stance]
        lateral = np.sum((track.base[:, stance] - mid) * right, axis=1)
        shift += (single * ch.weight_shift * lateral)[:, None] * right
    both = track.contact.all(axis=1)
    half_spread = np.sum((track.base[:, RIGHT] - mid) * right, axis=1)
    shift += (both * ch.load * half_spread)[:, None] * right
    shift = smooth(shift, 0.1 * fps)
    off = ch.pelvis
    xy = support + shift + off[:, :1] * right + off[:, 1:2] * fwd
    flex0 = np.radians(style.knee_flex_deg)
    thigh, shin = body.thigh_m, body.shin_m
    leg_drop = thigh + shin - np.sqrt(thigh**2 + shin**2 + 2 * thigh * shin * np.cos(flex0))
    z = body.hip_height_m - leg_drop + off[:, 2]
    return np.concatenate([xy, z[:, None]], -1), support


def _hips(body: BodyParams, pelvis: F64, r_pelvis: F64) -> dict[int, F64]:
    return {c: pelvis + apply(r_pelvis, np.array([c * body.hip_width_m / 2, 0.0, 0.0])) for c in (-1, 1)}


def _reach(body: BodyParams, pelvis: F64, r_pelvis: F64, ankles: dict[int, F64], fps: float) -> F64:
    """Lower (and, where that cannot do it, shift) the pelvis so that both legs reach their feet."""
    leg = REACH_MARGIN * (body.thigh_m + body.shin_m)
    out = pelvis.copy()
    for _ in range(2):
        hips = _hips(body, out, r_pelvis)
        drop = np.zeros(out.shape[0])
        pull = np.zeros((out.shape[0], 2))
        for c in (-1, 1):
            d = hips[c][:, :2] - ankles[c][:, :2]
            dxy = np.linalg.norm(d, axis=1)
            too_far = np.maximum(dxy - 0.97 * leg, 0.0)
            pull -= (too_far / np.maximum(dxy, 1e-9))[:, None] * d
            allowed = ankles[c][:, 2] + np.sqrt(np.maximum(leg**2 - np.minimum(dxy, 0.97 * leg) ** 2, 0.0))
            drop = np.maximum(drop, hips[c][:, 2] - allowed)
        drop = np.maximum(drop, 0.0)
        drop = np.maximum(drop, smooth(drop, 0.05 * fps))
        out[:, :2] += pull
        out[:, 2] -= drop
    return out


def _pose(
    body: BodyParams, style: MotionStyle, ch: Channels, track: FeetTrack, fps: float
) -> tuple[F64, F64]:
    n = ch.t.shape[0]
    pelvis, support = _pelvis_path(body, style, ch, track, fps)
    yaw = ch.yaw
    r_pelvis = rot_z(yaw + ch.pelvis_twist) @ rot_y(ch.pelvis_roll)
    ankles = {
        c: np.concatenate(
            [track.xy[:, f], (body.ankle_height_m + track.lift[:, f] + ch.heel[:, f])[:, None]], -1
        )
        for f, c in ((LEFT, -1), (RIGHT, 1))
    }
    pelvis = _reach(body, pelvis, r_pelvis, ankles, fps)
    hips = _hips(body, pelvis, r_pelvis)

    # Legs: knees by IK, bending along the foot's direction turned outward by knee_out.
    knees = {}
    for f, c in ((LEFT, -1), (RIGHT, 1)):
        a = track.yaw[:, f] - SIDE_SIGN[f] * ch.knee_out[:, f]
        pole = np.stack([-np.sin(a), np.cos(a), np.zeros(n)], -1)
        knees[c], ankles[c] = two_bone_ik(hips[c], ankles[c], body.thigh_m, body.shin_m, pole)

    # Arm-swing phase: + when the left leg is up (marching) or ahead (walking).
    lift_phase = smooth(track.swing[:, LEFT] - track.swing[:, RIGHT], 0.04 * fps)
    fwd = np.stack([-np.sin(yaw), np.cos(yaw)], -1)
    spread = np.sum((track.xy[:, LEFT] - track.xy[:, RIGHT]) * fwd, axis=1)
    walk_phase = np.clip(spread / 0.5, -1.0, 1.0)
    phase = (1.0 - ch.arm_walk) * lift_phase + ch.arm_walk * walk_phase
    swing_amp = smooth(ch.arm_swing, 0.1 * fps)

    # Trunk, shoulders and head.
    twist = ch.trunk_twist + swing_amp / 4 * phase
    pitch = np.radians(style.trunk_lean_deg) + ch.trunk_pitch
    roll = ch.trunk_roll - 0.5 * ch.pelvis_roll
    r_trunk = rot_z(yaw + twist) @ rot_x(-pitch) @ rot_y(roll)
    neck = pelvis + apply(r_trunk, np.array([0.0, 0.0, body.torso_m]))
    shoulders = {
        c: pelvis + apply(r_trunk, np.array([c * body.shoulder_width_m / 2, 0.0, body.torso_m]))
        for c in (-1, 1)
    }
    head_center = neck + apply(r_trunk, np.array([0.0, style.head_forward_m, body.neck_m]))
    r_head = rot_z(yaw + twist + ch.head_yaw) @ rot_x(-(ch.head_pitch + 0.6 * ch.trunk_pitch))
    face = head_center[:, None, :] + np.einsum("nij,kj->nki", r_head, FACE_OFFSETS_M * body.head_scale)

    # Arms: rest / swing, then the hand targets of behaviours and gestures, elbows by IK.
    r_body = rot_z(yaw)
    ua, fa = body.upper_arm_m, body.forearm_m
    feet_spread = np.sum(
        (track.xy[:, RIGHT] - track.xy[:, LEFT]) * np.stack([np.cos(yaw), np.sin(yaw)], -1), 1
    )
    out_wide = np.clip((feet_spread - style.stance_width_m) / 0.3, 0.0, 1.0)
    still_arms = smooth((ch.still > 0.5).astype(np.float64), CLASP_BLEND_S * fps / 2)
    elbow_extra = smooth(ch.elbow_flex, 0.1 * fps)
    elbows, wrists = {}, {}
    for c in (-1, 1):
        s = shoulders[c]
        swing = c * swing_amp * phase
        abduct = np.radians(6.0) + np.radians(12.0) * out_wide
        direction = np.stack(
            [c * np.sin(abduct), np.sin(swing) * np.cos(abduct), -np.cos(swing) * np.cos(abduct)], -1
        )
        flex = np.radians(style.elbow_flex_deg) + 0.5 * np.clip(swing, 0.0, None) + elbow_extra
        target = s + apply(r_trunk, direction) * arm_reach(ua, fa, flex)[:, None]
        pole = np.broadcast_to(np.array([c * 0.4, -1.0, 0.0]), (n, 3)).copy()
        if style.rest_arms == "clasped":
            clasp = pelvis + apply(r_trunk, np.array([c * 0.035, 0.17, -0.03]))
            w_c = still_arms[:, None]
            target = (1 - w_c) * target + w_c * clasp
            pole = (1 - w_c) * pole + w_c * np.array([c * 1.0, -0.5, -0.2])
        for arm in (p for p in ch.arms if p.side == c):
            w = arm.weight[:, None]
            goal = _arm_goal(
                arm, s, r_trunk, r_body, r_head, r_pelvis, head_center, hips[c], knees[c], support
            )
            target = _blend_reach(s, target, goal, w, apply(r_trunk, np.array([c * 0.6, 0.8, 0.0])))
            pole = (1 - w) * pole + w * np.asarray(arm.pole)
        elbows[c], wrists[c] = two_bone_ik(s, target, ua, fa, apply(r_trunk, pole))

    joints = np.empty((n, NUM_JOINTS, 3))
    joints[:, : FACE_OFFSETS_M.shape[0]] = face
    for c, lr in ((-1, "l"), (1, "r")):
        joints[:, J[f"{lr}_shoulder"]] = shoulders[c]
        joints[:, J[f"{lr}_elbow"]] = elbows[c]
        joints[:, J[f"{lr}_wrist"]] = wrists[c]
        joints[:, J[f"{lr}_hip"]] = hips[c]
        joints[:, J[f"{lr}_knee"]] = knees[c]
        joints[:, J[f"{lr}_ankle"]] = ankles[c]
    return joints, support


def _blend_reach(shoulder: F64, a: F64, b: F64, w: F64, via: F64) -> F64:
    """Hand targets from ``a`` towards ``b`` (weights ``w`` (T, 1)) as an arm moves: the direction
    from the shoulder turns (through ``via``, out and forward, when the two are far apart, as a
    raised arm does) and the reach changes, instead of the hand cutting through the shoulder."""
    va, vb = a - shoulder, b - shoulder
    ra, rb = np.linalg.norm(va, axis=1, keepdims=True), np.linalg.norm(vb, axis=1, keepdims=True)
    ua, ub = va / np.maximum(ra, 1e-9), vb / np.maximum(rb, 1e-9)
    apart = np.clip(0.5 * (1.0 - np.sum(ua * ub, axis=1, keepdims=True)), 0.0, 1.0)  # 1 when opposite
    d = (1 - w) * ua + w * ub + 4.0 * w * (1 - w) * apart * via
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)
    out: F64 = shoulder + d * ((1 - w) * ra + w * rb)
    return out


def _arm_goal(
    arm: ArmPose,
    shoulder: F64,
    r_trunk: F64,
    r_body: F64,
    r_head: F64,
    r_pelvis: F64,
    head_center: F64,
    hip: F64,
    knee: F64,
    support: F64,
) -> F64:
    """World position of an arm pose's hand target."""
    if arm.frame == "trunk":
        return shoulder + apply(r_trunk, arm.target)
    if arm.frame == "head":
        return head_center + apply(r_head, arm.target)
    if arm.frame == "hip":
        return hip + apply(r_pelvis, arm.target)
    if arm.frame == "knee":
        return knee + apply(r_body, arm.target)
    floor = np.concatenate([support, np.zeros((support.shape[0], 1))], -1)
    return floor + apply(r_body, arm.target)
