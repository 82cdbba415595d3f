"""Biovision Hierarchy (BVH) motion capture to COCO-17.

A BVH file has a ``HIERARCHY`` (``ROOT`` / ``JOINT`` blocks, each with its ``OFFSET`` from the
parent's origin and its ``CHANNELS``; ``End Site`` blocks close a chain) and a ``MOTION`` section
(``Frames:``, ``Frame Time:``, then one line of channel values per frame, in the order the channels
were declared). Forward kinematics (the format's convention): a joint's local rotation is the
product of its rotation channels in the order they are listed (``Zrotation Xrotation Yrotation``
is Rz Rx Ry, degrees); its world rotation W = W_parent R; its origin = the parent's origin +
W_parent (offset + its position channels, where it has them).

Files do not agree on units or axes, so :func:`to_cave` reads both from the body itself: up is the
axis along which the head stands above the feet at rest, forward is where the toes point from the
ankles, and the scale makes the body ``height_m`` tall (the distance from the soles to the top of
the head at rest). The person's left must then lie to the left of forward: a file whose left
joints come out on the right is mirrored and refused.

Joint mapping (by name, :data:`NAMES`: the Mixamo / MotionBuilder / Vicon ``LeftArm`` / ``LeftForeArm``
/ ``LeftHand`` / ``LeftUpLeg`` / ``LeftLeg`` / ``LeftFoot`` / ``LeftToeBase``; the CMU conversion's
``LeftShoulder`` / ``LeftElbow`` / ``LeftWrist`` / ``LeftHip`` / ``LeftKnee`` / ``LeftAnkle`` /
``LeftToe``; Xsens MVN's and Unity's ``LeftUpperArm`` / ``LeftUpperLeg`` / ``LeftLowerLeg`` (Unity:
``LeftLowerArm``, ``LeftToes``); OptiTrack Motive's ``LUArm`` / ``LFArm`` / ``LHand`` / ``LThigh`` /
``LShin`` / ``LFoot`` / ``LToe``; Poser / DAZ / Second Life's ``lShldr`` / ``lForeArm`` / ``lHand`` /
``lThigh`` / ``lShin`` / ``lFoot`` / ``lToe`` (DAZ Genesis: ``lShldrBend``, ``lForearmBend``,
``lThighBend``; Second Life: ``mShoulderLeft`` ... ``mAnkleLeft``, ``mFootLeft``); Bandai Namco-style
``UpperArm_L`` / ``LowerArm_L`` / ``Hand_L`` / ``UpperLeg_L`` / ``LowerLeg_L`` / ``Foot_L`` /
``Toes_L``; Blender Rigify's ``upper_arm.L`` / ``forearm.L`` / ``hand.L`` / ``thigh.L`` / ``shin.L``
/ ``foot.L`` / ``toe.L``; 3ds Max Biped's ``Bip01 L UpperArm`` / ``Forearm`` / ``Hand`` / ``Thigh`` /
``Calf`` / ``Foot`` / ``Toe0`` (spaces or underscores, ``Bip001``). A ``namespace:`` prefix is
ignored. Where a collarbone is named like a shoulder (Mixamo's and Xsens' ``LeftShoulder``,
Motive's ``LShoulder``) the upper arm's joint is the shoulder. Each COCO joint is the origin of
that BVH joint. A foot without a toe joint (Poser files) has its toe at the foot's End Site.
Face: the head joint (:data:`HEAD`) to its end (its End Site, or its child, where that lies up the
head at rest) is the head bone; a head
that ends in eye joints instead (Poser, DAZ) has its top :data:`HEAD_TOP` of the head joint's rest
height above the joint. With H the bone's midpoint, u up the bone, and f and s the skeleton's rest
forward (where the toes point at rest) and left turned by the head's world rotation: nose =
H + 0.095 f - 0.01 u, eyes = H + 0.08 f + 0.03 u +- 0.032 s, ears = H +- 0.075 s (the face rule of
:mod:`pipeline.mocap.acclaim`). The rest pose is every channel at 0 (the skeleton the offsets
draw), not the clip's first frame, which may be turned any way. Foot points for the floor: the
ankles and the toes.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

import numpy as np

from pipeline.errors import InputError
from pipeline.mocap.acclaim import FACE
from pipeline.mocap.kinematics import F64, axis_rotations
from pipeline.skeleton import NUM_JOINTS, J

NAMES = {  # COCO joint -> the BVH joint names that may stand for it (first match wins)
    # Mixamo / MotionBuilder / Vicon, CMU's conversion, Xsens MVN and Unity, OptiTrack Motive, Poser / DAZ,
    # Second Life, Bandai Namco-style, Blender Rigify, 3ds Max Biped. Order matters where a name
    # means two joints: Mixamo's and Xsens' LeftShoulder is the collarbone, CMU's the shoulder.
    "l_shoulder": ("LeftArm", "LeftUpperArm", "LeftShoulder", "LUArm", "lShldr", "lShldrBend",
                   "mShoulderLeft", "UpperArm_L", "upper_arm.L", "Bip01 L UpperArm"),
    "r_shoulder": ("RightArm", "RightUpperArm", "RightShoulder", "RUArm", "rShldr", "rShldrBend",
                   "mShoulderRight", "UpperArm_R", "upper_arm.R", "Bip01 R UpperArm"),
    "l_elbow": ("LeftForeArm", "LeftElbow", "LeftLowerArm", "LFArm", "lForeArm", "lForearmBend",
                "mElbowLeft", "LowerArm_L", "forearm.L", "Bip01 L Forearm"),
    "r_elbow": ("RightForeArm", "RightElbow", "RightLowerArm", "RFArm", "rForeArm", "rForearmBend",
                "mElbowRight", "LowerArm_R", "forearm.R", "Bip01 R Forearm"),
    "l_wrist": ("LeftHand", "LeftWrist", "LHand", "lHand", "mWristLeft", "Hand_L", "hand.L",
                "Bip01 L Hand"),
    "r_wrist": ("RightHand", "RightWrist", "RHand", "rHand", "mWristRight", "Hand_R", "hand.R",
                "Bip01 R Hand"),
    "l_hip": ("LeftUpLeg", "LeftHip", "LeftUpperLeg", "LThigh", "lThigh", "lThighBend", "mHipLeft",
              "UpperLeg_L", "thigh.L", "Bip01 L Thigh"),
    "r_hip": ("RightUpLeg", "RightHip", "RightUpperLeg", "RThigh", "rThigh", "rThighBend", "mHipRight",
              "UpperLeg_R", "thigh.R", "Bip01 R Thigh"),
    "l_knee": ("LeftLeg", "LeftKnee", "LeftLowerLeg", "LShin", "lShin", "mKneeLeft", "LowerLeg_L",
               "shin.L", "Bip01 L Calf"),
    "r_knee": ("RightLeg", "RightKnee", "RightLowerLeg", "RShin", "rShin", "mKneeRight", "LowerLeg_R",
               "shin.R", "Bip01 R Calf"),
    "l_ankle": ("LeftFoot", "LeftAnkle", "LFoot", "lFoot", "mAnkleLeft", "Foot_L", "foot.L",
                "Bip01 L Foot"),
    "r_ankle": ("RightFoot", "RightAnkle", "RFoot", "rFoot", "mAnkleRight", "Foot_R", "foot.R",
                "Bip01 R Foot"),
}
TOES = (
    ("LeftToeBase", "LeftToe", "LeftToes", "LToe", "lToe", "mFootLeft", "Toes_L", "toe.L",
     "Bip01 L Toe0"),
    ("RightToeBase", "RightToe", "RightToes", "RToe", "rToe", "mFootRight", "Toes_R", "toe.R",
     "Bip01 R Toe0"),
)
HEAD = ("Head", "head", "mHead", "Bip01 Head")
# Where the file gives the head no end up its bone (Poser and DAZ files end the head in eye joints):
# its top lies this share of the head joint's height above the soles (at rest) above the joint, up.
HEAD_TOP = 0.13
_CHANNELS = ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation")


@dataclass(frozen=True, slots=True)
class Joint:
    """One joint of the hierarchy: its parent (index, -1 for the root), offset and channels."""

    name: str
    parent: int
    offset: tuple[float, float, float]
    channels: tuple[str, ...]
    end: tuple[float, float, float] | None = None  # its End Site's offset, if it has one


@dataclass(frozen=True, slots=True)
class Bvh:
    """A parsed BVH file: its joints (parents before children), frame time and channel values."""

    joints: tuple[Joint, ...]
    frame_time_s: float
    values: F64  # (T, channels)

    def index(self, *names: str) -> int | None:
        """The index of the first joint named one of ``names`` (None if none is there); a namespace
        prefix (``mixamorig:LeftUpLeg``, as FBX-to-BVH exports write it) does not count, nor the
        number or the separators of a 3ds Max Biped name (``Bip001_L_Thigh`` is ``Bip01 L Thigh``)."""
        plain = [_plain_name(j.name) for j in self.joints]
        for n in names:
            for i, j in enumerate(self.joints):
                if j.name == n or plain[i] == n:
                    return i
        return None


_BIPED = re.compile(r"^Bip0*1[ _]")


def _plain_name(name: str) -> str:
    """A joint's name without a ``namespace:`` prefix, a Biped name as ``Bip01 L Thigh``."""
    name = name.rsplit(":", 1)[-1]
    if _BIPED.match(name):
        name = "Bip01 " + _BIPED.sub("", name).replace("_", " ")
    return name


def parse_bvh(text: str, name: str = "bvh") -> Bvh:
    """Parse a BVH file; :class:`InputError` (naming ``name``) when it is not one."""
    head, sep, motion = text.partition("MOTION")
    if not sep or "HIERARCHY" not in head:
        raise InputError(f"{name}: not a BVH file (no HIERARCHY and MOTION sections)")
    tokens = head.split("HIERARCHY", 1)[1].split()
    joints: list[Joint] = []
    stack: list[int] = []  # the open blocks: joint indices, -2 for an End Site
    name_next: str | None = None  # the joint whose block opens next (None: an End Site's)
    i = 0
    try:
        while i < len(tokens):
            tok = tokens[i]
            if tok in ("ROOT", "JOINT"):  # the name runs to the brace: 3ds Max writes "Bip01 L Thigh"
                end = tokens.index("{", i + 1)
                if end == i + 1:
                    raise InputError(f"{name}: a {tok} without a name")
                name_next = " ".join(tokens[i + 1 : end])
                i = end
            elif tok == "End":  # End Site
                name_next = None
                i += 2
            elif tok == "{":
                if name_next is None:
                    stack.append(-2)
                else:
                    joints.append(Joint(name_next, stack[-1] if stack else -1, (0.0, 0.0, 0.0), ()))
                    stack.append(len(joints) - 1)
                i += 1
            elif tok == "}":
                stack.pop()
                i += 1
            elif tok == "OFFSET":
                off = (float(tokens[i + 1]), float(tokens[i + 2]), float(tokens[i + 3]))
                top = stack[-1]
                if top == -2:  # an End Site: the end of the joint that holds it
                    owner = stack[-2]
                    joints[owner] = _with(joints[owner], end=off)
                else:
                    joints[top] = _with(joints[top], offset=off)
                i += 4
            elif tok == "CHANNELS":
                n = int(tokens[i + 1])
                chans = tuple(tokens[i + 2 : i + 2 + n])
                bad = [c for c in chans if c not in _CHANNELS]
                if bad:
                    raise InputError(f"{name}: unknown channels {bad}")
                if stack[-1] < 0:
                    raise InputError(f"{name}: CHANNELS inside an End Site")
                joints[stack[-1]] = _with(joints[stack[-1]], channels=chans)
                i += 2 + n
            else:
                raise InputError(f"{name}: unexpected {tok!r} in the hierarchy")
    except (IndexError, ValueError) as exc:
        raise InputError(f"{name}: malformed hierarchy ({exc})") from exc
    if not joints or stack:
        raise InputError(f"{name}: the hierarchy has no joints or unbalanced braces")
    frames = re.search(r"Frames:\s*(\d+)", motion)
    ftime = re.search(r"Frame Time:\s*([0-9.eE+-]+)", motion)
    if frames is None or ftime is None:
        raise InputError(f"{name}: MOTION lacks Frames: or Frame Time:")
    body = motion[ftime.end() :].split()
    width = sum(len(j.channels) for j in joints)
    n = int(frames.group(1))
    try:
        values = np.asarray(body, dtype=np.float64)
    except ValueError as exc:
        raise InputError(f"{name}: non-numeric motion values ({exc})") from exc
    if n < 2 or values.size < n * width:
        raise InputError(f"{name}: {values.size} motion values for {n} frames of {width} channels")
    try:
        dt = float(ftime.group(1))
    except ValueError as exc:
        raise InputError(f"{name}: Frame Time is not a number ({exc})") from exc
    if not dt > 0:
        raise InputError(f"{name}: Frame Time must be positive, got {dt}")
    return Bvh(tuple(joints), dt, values[: n * width].reshape(n, width))


def _with(j: Joint, **changes: object) -> Joint:
    return replace(j, **changes)  # type: ignore[arg-type]


def world(bvh: Bvh) -> tuple[F64, F64, F64]:
    """Each joint's world origin (T, N, 3), rotation (T, N, 3, 3) and end (T, N, 3: its End Site,
    or its first child's origin; its origin if it has neither), in the file's axes and units."""
    t = len(bvh.values)
    n = len(bvh.joints)
    origin = np.zeros((t, n, 3))
    rot = np.zeros((t, n, 3, 3))
    col = 0
    for k, j in enumerate(bvh.joints):
        local = np.broadcast_to(np.eye(3), (t, 3, 3)).copy()
        shift = np.broadcast_to(np.asarray(j.offset), (t, 3)).copy()
        for c in j.channels:
            v = bvh.values[:, col]
            col += 1
            axis = c[0].lower()
            if c.endswith("position"):
                shift[:, "xyz".index(axis)] += v
            else:
                local = local @ axis_rotations(axis, v)
        if j.parent < 0:
            origin[:, k], rot[:, k] = shift, local
        else:
            origin[:, k] = origin[:, j.parent] + np.einsum("tij,tj->ti", rot[:, j.parent], shift)
            rot[:, k] = rot[:, j.parent] @ local
    end = origin.copy()
    for k, j in enumerate(bvh.joints):
        if j.end is not None:
            end[:, k] = origin[:, k] + np.einsum("tij,j->ti", rot[:, k], np.asarray(j.end))
        else:
            child = next((c for c, cj in enumerate(bvh.joints) if cj.parent == k), None)
            if child is not None:
                end[:, k] = origin[:, child]
    return origin, rot, end


@dataclass(frozen=True, slots=True)
class Posed:
    """COCO-17 joints (T, 17, 3), foot points (T, 4, 3) and pelvis (T, 3), CAVE axes, metres."""

    joints: F64
    foot_points: F64
    pelvis: F64


def _need(bvh: Bvh, names: tuple[str, ...], name: str) -> int:
    k = bvh.index(*names)
    if k is None:
        raise InputError(f"{name}: no joint named {' or '.join(names)}")
    return k


def _toes(bvh: Bvh, origin: F64, end: F64, ankles: list[int], name: str) -> F64:
    """The toe points (T, 2, 3): each toe joint's origin, or where there is none (Poser and DAZ files
    end the foot in an End Site) the foot's end."""
    out = []
    for names, ankle in zip(TOES, ankles, strict=True):
        k = bvh.index(*names)
        if k is None and bvh.joints[ankle].end is None:
            raise InputError(f"{name}: no joint named {' or '.join(names)}, and the foot has no End Site")
        out.append(origin[:, k] if k is not None else end[:, ankle])
    return np.stack(out, axis=1)


def _unit(v: F64) -> F64:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def to_cave(bvh: Bvh, height_m: float, name: str = "bvh") -> Posed:
    """The clip's COCO-17 joints in CAVE axes (X right, Y forward, Z up) and metres, the body
    ``height_m`` tall (see the module docstring)."""
    if not 0.5 < height_m < 2.5:
        raise InputError(f"{name}: height_m must be in (0.5, 2.5) m, got {height_m}")
    origin, rot, end = world(bvh)
    idx = {coco: _need(bvh, names, name) for coco, names in NAMES.items()}
    head = _need(bvh, HEAD, name)
    ankles = [idx["l_ankle"], idx["r_ankle"]]
    toe_pts = _toes(bvh, origin, end, ankles, name)
    # the rest pose (every channel 0): the skeleton's own up, forward and left, which the head's
    # world rotation turns into where the face looks in each frame
    r_origin, _, r_end = world(replace(bvh, values=np.zeros((1, bvh.values.shape[1]))))
    r_feet = np.concatenate([r_origin[0, ankles], _toes(bvh, r_origin, r_end, ankles, name)[0]])
    rest_up = _unit(r_origin[0, head] - r_feet.mean(axis=0))
    rest_fwd = (r_feet[2:] - r_feet[:2]).mean(axis=0)
    rest_fwd -= (rest_fwd @ rest_up) * rest_up
    if not np.linalg.norm(rest_fwd) > 1e-6 * np.linalg.norm(r_origin[0, head] - r_feet.mean(axis=0)):
        raise InputError(f"{name}: at rest the toes do not point forward (cannot tell where the face looks)")
    rest_fwd = _unit(rest_fwd)
    rest_left = np.cross(rest_up, rest_fwd)
    bone = r_end[0, head] - r_origin[0, head]
    if np.linalg.norm(bone) > 0 and _unit(bone) @ rest_up > np.cos(np.radians(30.0)):
        top = end[:, head]  # the head's End Site or child lies up its bone
    else:
        head_len = HEAD_TOP * float((r_origin[0, head] - r_feet.min(axis=0)) @ rest_up)
        top = origin[:, head] + np.einsum("tij,j->ti", rot[:, head], head_len * rest_up)
    foot_pts = np.concatenate([origin[:, ankles], toe_pts], axis=1)
    up_vec = np.median(top - foot_pts.mean(axis=1), axis=0)
    up_axis = int(np.argmax(np.abs(up_vec)))
    up = np.zeros(3)
    up[up_axis] = np.sign(up_vec[up_axis])
    # forward: where the toes point from the ankles, in the frame where they point most alike (a yaw
    # of the whole clip does not matter: the recogniser reads the body's own facing)
    toe_dir = (toe_pts - origin[:, ankles]).mean(axis=1)
    toe_dir -= np.outer(toe_dir @ up, up)
    fwd = toe_dir[int(np.argmax(np.linalg.norm(toe_dir, axis=1)))]
    if np.linalg.norm(fwd) < 1e-9:
        raise InputError(f"{name}: the toes do not point anywhere (cannot tell forward)")
    fwd = fwd / np.linalg.norm(fwd)
    left = np.cross(up, fwd)  # in a right-handed frame, up x forward points to the person's left
    per_frame_left = np.cross(up, toe_dir)
    side = np.median(np.einsum("ti,ti->t", origin[:, idx["l_hip"]] - origin[:, idx["r_hip"]], per_frame_left))
    if side <= 0:
        raise InputError(f"{name}: the left hip lies to the right of forward (a mirrored file)")
    # rows: CAVE X (right) = -left, Y = forward, Z = up
    to_cave_m = np.stack([-left, fwd, up])
    # standing height: the head's top above the lowest foot point, at the clip's tallest (95th
    # percentile); the soles lie about 4 % of the height below the ankles
    lowest = np.min(foot_pts @ up, axis=1)
    height_units = float(np.percentile(top @ up - lowest, 95)) / 0.96
    if not height_units > 0:
        raise InputError(f"{name}: the head is not above the feet")
    scale = height_m / height_units
    pts = origin @ to_cave_m.T * scale
    out = np.full((len(origin), NUM_JOINTS, 3), np.nan)
    for coco, k in idx.items():
        out[:, J[coco]] = pts[:, k]
    h0 = origin[:, head] @ to_cave_m.T * scale
    h1 = top @ to_cave_m.T * scale
    mid = 0.5 * (h0 + h1)
    u = _unit(h1 - h0)
    # the head's own frame: the skeleton's rest forward and left, turned with the head's world rotation
    f = np.einsum("ij,tjk,k->ti", to_cave_m, rot[:, head], rest_fwd)
    s = np.einsum("ij,tjk,k->ti", to_cave_m, rot[:, head], rest_left)
    for coco, (df, du, ds) in FACE.items():
        out[:, J[coco]] = mid + df * f + du * u + ds * s
    feet = foot_pts @ to_cave_m.T * scale
    pelvis = 0.5 * (out[:, J["l_hip"]] + out[:, J["r_hip"]])
    return Posed(out, feet, pelvis)
