"""DeepMimic humanoid clips (``humanoid3d_*.txt``, pybullet's ``data/motions``) to COCO-17.

Source format: JSON ``{"Loop": "wrap"|"none", "Frames": [[...44 numbers...], ...]}``; per frame
``[0]`` the frame's duration in seconds, ``[1:4]`` the root position (metres), then quaternions
in (w, x, y, z) order, each local to its parent: ``[4:8]`` root, ``[8:12]`` chest, ``[12:16]``
neck, ``[16:20]`` right hip, ``[20]`` right knee angle (rad, about the joint's z axis),
``[21:25]`` right ankle, ``[25:29]`` right shoulder, ``[29]`` right elbow angle, ``[30:34]`` left
hip, ``[34]`` left knee, ``[35:39]`` left ankle, ``[39:43]`` left shoulder, ``[43]`` left elbow
(the layout pybullet's ``humanoid_pose_interpolator.py`` reads).

Model: ``pybullet_data/humanoid/humanoid.urdf`` gives the joint offsets (parent frame, every
joint frame aligned with its parent's at rest: rpy = 0); pybullet's DeepMimic environment loads
it with ``globalScaling = 0.25``, which is the scale the clips' root positions are in. The
model's frame is +Y up, +X forward (the feet's boxes point to +X) and +Z to the person's right;
the CAVE frame gets X_cave = z, Y_cave = x, Z_cave = y (a proper rotation).

Joint mapping (DeepMimic joint -> COCO keypoint; every COCO point is a joint centre of the
model, no offset, except the face, which the model does not have):
    left/right_shoulder -> l/r_shoulder   left/right_elbow -> l/r_elbow
    left/right_wrist (fixed joint at the end of the forearm) -> l/r_wrist
    left/right_hip -> l/r_hip   left/right_knee -> l/r_knee   left/right_ankle -> l/r_ankle
Face rule (model has a head sphere, radius 0.1025 m, centred 0.175 m above the neck joint along
the neck link's up axis): in the neck link's frame (x forward, y up, z right) with the head
centre H: nose = H + (0.095, -0.010, 0), eyes = H + (0.080, 0.030, -/+0.032) (left eye at -z),
ears = H + (0.000, 0.000, -/+0.075) -- points on the head sphere's surface, front and sides.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pipeline.errors import InputError
from pipeline.mocap.kinematics import (
    F64,
    axis_angle_quat,
    quat_mul,
    quat_normalize,
    quat_to_matrix,
    resample_linear,
    resample_quat,
    resample_times,
)
from pipeline.skeleton import NUM_JOINTS, J

URDF_SCALE = 0.25  # pybullet's DeepMimic env: loadURDF("humanoid/humanoid.urdf", globalScaling=0.25)
FRAME_WIDTH = 44
# Source (x fwd, y up, z right) -> CAVE (x right, y fwd, z up): rows are CAVE axes.
SRC_TO_CAVE: F64 = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
SPHERICAL = ("chest", "neck", "right_hip", "right_ankle", "right_shoulder",
             "left_hip", "left_ankle", "left_shoulder")
# Offsets of the quaternions / angles in a frame (after the duration and the root position).
ROOT_Q = 4
QUAT_AT = {"chest": 8, "neck": 12, "right_hip": 16, "right_ankle": 21, "right_shoulder": 25,
           "left_hip": 30, "left_ankle": 35, "left_shoulder": 39}
ANGLE_AT = {"right_knee": 20, "right_elbow": 29, "left_knee": 34, "left_elbow": 43}
PARENT = {"chest": "root", "neck": "chest", "right_hip": "root", "right_knee": "right_hip",
          "right_ankle": "right_knee", "right_shoulder": "chest", "right_elbow": "right_shoulder",
          "right_wrist": "right_elbow", "left_hip": "root", "left_knee": "left_hip",
          "left_ankle": "left_knee", "left_shoulder": "chest", "left_elbow": "left_shoulder",
          "left_wrist": "left_elbow"}
ORDER = tuple(PARENT)  # parents come before children
COCO_FROM = {"l_shoulder": "left_shoulder", "r_shoulder": "right_shoulder",
             "l_elbow": "left_elbow", "r_elbow": "right_elbow",
             "l_wrist": "left_wrist", "r_wrist": "right_wrist",
             "l_hip": "left_hip", "r_hip": "right_hip", "l_knee": "left_knee",
             "r_knee": "right_knee", "l_ankle": "left_ankle", "r_ankle": "right_ankle"}
HEAD_ABOVE_NECK_M = 0.175
FACE_IN_NECK_FRAME = {  # offsets from the head centre, neck link frame (x fwd, y up, z right)
    "nose": (0.095, -0.010, 0.0),
    "l_eye": (0.080, 0.030, -0.032),
    "r_eye": (0.080, 0.030, 0.032),
    "l_ear": (0.0, 0.0, -0.075),
    "r_ear": (0.0, 0.0, 0.075),
}


@dataclass(frozen=True, slots=True)
class HumanoidModel:
    """The DeepMimic humanoid at clip scale: joint offsets (metres, parent frame) and feet.

    offsets: joint name -> (3,) offset of the joint from its parent joint.
    knee_axis / elbow_axis: (3,) the revolute joints' axis in the parent frame.
    foot_corners: (4, 3) the sole's corners in the ankle frame (the bottom of the foot box).
    """

    offsets: dict[str, tuple[float, float, float]]
    knee_axis: tuple[float, float, float]
    elbow_axis: tuple[float, float, float]
    foot_corners: tuple[tuple[float, float, float], ...]

    def __post_init__(self) -> None:
        missing = sorted(set(PARENT) - set(self.offsets))
        if missing:
            raise InputError(f"humanoid model lacks the joints {missing}")
        if len(self.foot_corners) != 4:
            raise InputError("humanoid model needs the 4 sole corners of the foot box")


def _floats(text: str | None) -> tuple[float, float, float]:
    vals = tuple(float(v) for v in (text or "").split())
    if len(vals) != 3:
        raise InputError(f"expected three numbers, got {text!r}")
    return vals  # type: ignore[return-value]


def load_humanoid_urdf(path: Path, scale: float = URDF_SCALE) -> HumanoidModel:
    """Read the joint offsets and the foot box from pybullet's ``humanoid/humanoid.urdf``."""
    try:
        root = ET.fromstring(path.read_bytes().rstrip(b"\x00"))
    except (OSError, ET.ParseError) as exc:
        raise InputError(f"{path}: not a readable URDF ({exc})") from exc
    offsets: dict[str, tuple[float, float, float]] = {}
    axes: dict[str, tuple[float, float, float]] = {}
    for joint in root.iter("joint"):
        name = joint.get("name", "")
        origin = joint.find("origin")
        parent = joint.find("parent")
        if name in PARENT and origin is not None and parent is not None:
            if parent.get("link") != PARENT[name]:
                raise InputError(f"{path}: joint {name} hangs from {parent.get('link')}, "
                                 f"expected {PARENT[name]}")
            if any(abs(v) > 1e-9 for v in _floats(origin.get("rpy"))):
                raise InputError(f"{path}: joint {name} has a rotated frame; not supported")
            offsets[name] = tuple(scale * v for v in _floats(origin.get("xyz")))  # type: ignore[assignment]
            axis = joint.find("axis")
            if axis is not None:
                axes[name] = _floats(axis.get("xyz"))
    box = None
    for link in root.iter("link"):
        if link.get("name") == "right_ankle":
            origin = link.find("collision/origin")
            geom = link.find("collision/geometry/box")
            if origin is not None and geom is not None:
                box = (np.array(_floats(origin.get("xyz")), dtype=np.float64) * scale,
                       np.array(_floats(geom.get("size")), dtype=np.float64) * scale)
    if box is None:
        raise InputError(f"{path}: no foot box on the right_ankle link")
    c, s = box
    sole_y = c[1] - s[1] / 2
    corners = tuple((float(c[0] + sx * s[0] / 2), float(sole_y), float(c[2] + sz * s[2] / 2))
                    for sx in (-1, 1) for sz in (-1, 1))
    return HumanoidModel(offsets, axes.get("right_knee", (0.0, 0.0, 1.0)),
                         axes.get("right_elbow", (0.0, 0.0, 1.0)), corners)


@dataclass(frozen=True, slots=True)
class DeepMimicClip:
    """A parsed clip: frame times (T,) s, root position (T, 3), local rotations as quaternions.

    rotations: joint name -> (T, 4) (w, x, y, z), incl. ``root`` and the revolute joints
    (converted from their angle about the model's axis).
    """

    times_s: F64
    root_pos: F64
    rotations: dict[str, F64]
    loop: bool

    @property
    def duration_s(self) -> float:
        return float(self.times_s[-1])


def parse_clip(text: str, model: HumanoidModel, name: str = "clip") -> DeepMimicClip:
    """Parse a DeepMimic motion file's JSON text."""
    try:
        data = json.loads(text)
        frames = np.asarray(data["Frames"], dtype=np.float64)
    except (ValueError, KeyError, TypeError) as exc:
        raise InputError(f"{name}: not a DeepMimic motion file ({exc})") from exc
    if frames.ndim != 2 or frames.shape[1] != FRAME_WIDTH or len(frames) < 2:
        raise InputError(f"{name}: expected at least 2 frames of {FRAME_WIDTH} numbers, "
                         f"got {frames.shape}")
    if not np.all(np.isfinite(frames)) or np.any(frames[:-1, 0] <= 0):
        raise InputError(f"{name}: frames must be finite with positive durations")
    times = np.concatenate([[0.0], np.cumsum(frames[:-1, 0])])
    rot: dict[str, F64] = {"root": quat_normalize(frames[:, ROOT_Q:ROOT_Q + 4])}
    for joint, at in QUAT_AT.items():
        rot[joint] = quat_normalize(frames[:, at:at + 4])
    for joint, at in ANGLE_AT.items():
        axis = model.knee_axis if "knee" in joint else model.elbow_axis
        rot[joint] = axis_angle_quat(np.asarray(axis), frames[:, at])
    rot["right_wrist"] = rot["left_wrist"] = np.tile([1.0, 0.0, 0.0, 0.0], (len(frames), 1))
    return DeepMimicClip(times, frames[:, 1:4].copy(), rot, str(data.get("Loop", "none")) == "wrap")


def _yaw_about_up(q: F64) -> F64:
    """Heading (rad) about the model's +Y of the rotations q (T, 4): angle of the rotated +X."""
    fwd = quat_to_matrix(q)[:, :, 0]
    return np.arctan2(-fwd[:, 2], fwd[:, 0])


def tile_cycles(clip: DeepMimicClip, cycles: int) -> DeepMimicClip:
    """Repeat a looping clip ``cycles`` times, each cycle carried on from where the last ended.

    The last frame of a ``wrap`` clip is the first pose again, moved and turned by the cycle's
    horizontal travel and heading change; each repeat applies that rigid motion (about +Y)
    once more, as DeepMimic's own cycle offset does.
    """
    if cycles <= 1:
        return clip
    yaw = _yaw_about_up(clip.rotations["root"][[0, -1]])
    d_yaw = float(yaw[1] - yaw[0])
    c, s = np.cos(d_yaw), np.sin(d_yaw)
    rot_y = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])  # about +Y by d_yaw
    q_yaw = axis_angle_quat(np.array([0.0, 1.0, 0.0]), np.array([d_yaw]))[0]
    p0, p1 = clip.root_pos[0], clip.root_pos[-1]
    pos, root_q = [clip.root_pos], [clip.rotations["root"]]
    cur_pos, cur_q = clip.root_pos, clip.rotations["root"]
    for _ in range(cycles - 1):
        nxt = (cur_pos - p0) @ rot_y.T + p1
        nxt[:, 1] = clip.root_pos[:, 1]  # height is never carried over
        cur_q = quat_mul(np.broadcast_to(q_yaw, cur_q.shape), cur_q)
        cur_pos = nxt
        pos.append(cur_pos[1:])
        root_q.append(cur_q[1:])
    period = clip.duration_s
    times = np.concatenate([clip.times_s] + [clip.times_s[1:] + k * period for k in range(1, cycles)])
    rot = {j: (np.concatenate([q] + [q[1:]] * (cycles - 1)) if j != "root" else np.concatenate(root_q))
           for j, q in clip.rotations.items()}
    return DeepMimicClip(times, np.concatenate(pos), rot, clip.loop)


def resample(clip: DeepMimicClip, fps: float) -> DeepMimicClip:
    """The clip at ``fps`` (slerp of rotations, linear root position)."""
    t = resample_times(clip.duration_s, fps)
    return DeepMimicClip(
        t,
        resample_linear(clip.times_s, clip.root_pos, t),
        {j: resample_quat(clip.times_s, q, t) for j, q in clip.rotations.items()},
        clip.loop,
    )


@dataclass(frozen=True, slots=True)
class Posed:
    """Forward kinematics of a clip in the CAVE frame (metres, before floor placement).

    joints: (T, 17, 3) COCO-17; foot_points: (T, 8, 3) both soles' corners (left 4, right 4);
    pelvis: (T, 3) the root joint.
    """

    joints: F64
    foot_points: F64
    pelvis: F64


def forward_kinematics(clip: DeepMimicClip, model: HumanoidModel) -> Posed:
    """World positions of the model's joints over the clip, mapped to COCO-17 in CAVE axes."""
    n = len(clip.times_s)
    world_r: dict[str, F64] = {"root": quat_to_matrix(clip.rotations["root"])}
    world_p: dict[str, F64] = {"root": clip.root_pos}
    for joint in ORDER:
        parent = PARENT[joint]
        off = np.asarray(model.offsets[joint])
        world_p[joint] = world_p[parent] + world_r[parent] @ off
        world_r[joint] = world_r[parent] @ quat_to_matrix(clip.rotations[joint])
    out = np.full((n, NUM_JOINTS, 3), np.nan)
    for coco, src in COCO_FROM.items():
        out[:, J[coco]] = world_p[src]
    head = world_p["neck"] + world_r["neck"] @ np.array([0.0, HEAD_ABOVE_NECK_M, 0.0])
    for coco, face in FACE_IN_NECK_FRAME.items():
        out[:, J[coco]] = head + world_r["neck"] @ np.asarray(face)
    corners = np.asarray(model.foot_corners).T  # (3, 4)
    feet = np.concatenate(
        [world_p[a][:, :, None] + world_r[a] @ corners for a in ("left_ankle", "right_ankle")], axis=2
    ).transpose(0, 2, 1)
    return Posed(out @ SRC_TO_CAVE.T, feet @ SRC_TO_CAVE.T, world_p["root"] @ SRC_TO_CAVE.T)
