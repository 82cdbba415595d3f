"""Acclaim ASF/AMC motion capture (the CMU Graphics Lab database's format) to COCO-17.

ASF (skeleton): ``:units`` (``length`` L: lengths and root translations are in inches / L,
so metres = value x 0.0254 / L; ``angle deg``), ``:root`` (``order`` of the root's six
values, ``orientation``), ``:bonedata`` (per bone ``name``, unit ``direction`` and ``length``
in the global frame at rest, ``axis`` (three angles and an order: the bone's local frame C),
``dof``), ``:hierarchy`` (parent child ...). AMC (motion): per frame its number, then per bone
its ``dof`` values in the ``dof`` order (degrees).

Forward kinematics (the CMU/Acclaim convention, as in the database's own viewer): a bone's
rotation M is the product of its dof rotations composed in the fixed order
``Rz(rz) Ry(ry) Rx(rx)``; its world rotation W = W_parent C M C^-1; its start is the parent's
end; its end = start + length x W direction. The root: W = C_root M_root C_root^-1 with the
root's rotation values, position = its translation values.

Axes: the database is +Y up with the person's left at +X at rest (``lfemur`` points to +X),
so forward is +Z; CAVE X (right) = -x, Y (forward) = z, Z (up) = y (a proper rotation).

Joint mapping (bone -> COCO keypoint): shoulder = start of ``l/rhumerus`` (the end of the
clavicle), elbow = start of ``l/rradius``, wrist = start of ``l/rwrist``, hip = start of
``l/rfemur`` (the end of ``l/rhipjoint``), knee = start of ``l/rtibia``, ankle = start of
``l/rfoot``. Face: the ``head`` bone runs from the top of the neck to the top of the head;
with H its midpoint, f its frame's forward axis (local +Z) and s its left axis (local +X)
and u up the bone: nose = H + 0.095 f - 0.01 u, eyes = H + 0.08 f + 0.03 u +- 0.032 s,
ears = H +- 0.075 s (the same face rule as :mod:`pipeline.mocap.deepmimic`).
Foot points for the floor: the ends of ``l/rfoot`` and ``l/rtoes`` and the ankles.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from pipeline.errors import InputError
from pipeline.mocap.kinematics import F64, axis_rotations
from pipeline.skeleton import NUM_JOINTS, J

SRC_TO_CAVE: F64 = np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
INCH_M = 0.0254
COCO_FROM_START = {
    "l_shoulder": "lhumerus",
    "r_shoulder": "rhumerus",
    "l_elbow": "lradius",
    "r_elbow": "rradius",
    "l_wrist": "lwrist",
    "r_wrist": "rwrist",
    "l_hip": "lfemur",
    "r_hip": "rfemur",
    "l_knee": "ltibia",
    "r_knee": "rtibia",
    "l_ankle": "lfoot",
    "r_ankle": "rfoot",
}
FOOT_ENDS = ("lfoot", "ltoes", "rfoot", "rtoes")
FACE = {  # (forward, up, left) offsets from the head bone's midpoint, metres
    "nose": (0.095, -0.010, 0.0),
    "l_eye": (0.080, 0.030, 0.032),
    "r_eye": (0.080, 0.030, -0.032),
    "l_ear": (0.0, 0.0, 0.075),
    "r_ear": (0.0, 0.0, -0.075),
}


def _euler(values: dict[str, F64], n: int) -> F64:
    """Rz Ry Rx of the given per-axis degrees (missing axes 0): (T, 3, 3)."""
    zero = np.zeros(n)
    return (
        axis_rotations("z", values.get("z", zero))
        @ axis_rotations("y", values.get("y", zero))
        @ axis_rotations("x", values.get("x", zero))
    )


@dataclass(frozen=True, slots=True)
class Bone:
    name: str
    direction: tuple[float, float, float]
    length_m: float
    axis_deg: tuple[float, float, float]
    axis_order: str
    dof: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class Skeleton:
    """An ASF skeleton: bones, parent of each bone, root dof order, metres per file unit."""

    bones: dict[str, Bone]
    parent: dict[str, str]
    root_order: tuple[str, ...]
    root_axis: tuple[float, float, float]
    unit_m: float
    order: tuple[str, ...]  # bones, parents first


def _section(text: str, name: str) -> str:
    m = re.search(rf"^:{name}\b(.*?)(?=^:|\Z)", text, re.S | re.M)
    return m.group(1) if m else ""


def parse_asf(text: str, name: str = "asf") -> Skeleton:
    """Parse an ASF skeleton file."""
    text = text.replace("\r", "")
    if ":bonedata" not in text or ":hierarchy" not in text:
        raise InputError(f"{name}: not an ASF file (no :bonedata / :hierarchy)")
    length_unit = 1.0
    m = re.search(r"^\s*length\s+([-\d.eE+]+)", _section(text, "units"), re.M)
    if m:
        length_unit = float(m.group(1))
    unit_m = INCH_M / length_unit
    root = _section(text, "root")
    mo = re.search(r"order\s+(.+)", root)
    order_words = mo.group(1).split() if mo else ["tx", "ty", "tz", "rx", "ry", "rz"]
    root_order = tuple(t.lower() for t in order_words)
    mo = re.search(r"orientation\s+(.+)", root)
    root_axis = tuple(float(v) for v in mo.group(1).split()[:3]) if mo else (0.0, 0.0, 0.0)
    bones: dict[str, Bone] = {}
    for block in re.findall(r"begin(.*?)end", _section(text, "bonedata"), re.S):
        fields: dict[str, list[str]] = {}
        for line in block.strip().splitlines():
            parts = line.split()
            if parts and parts[0] in ("name", "direction", "length", "axis", "dof"):
                fields[parts[0]] = parts[1:]
        try:
            axis = fields.get("axis", ["0", "0", "0", "XYZ"])
            bone = Bone(
                fields["name"][0],
                tuple(float(v) for v in fields["direction"][:3]),  # type: ignore[arg-type]
                float(fields["length"][0]) * unit_m,
                tuple(float(v) for v in axis[:3]),  # type: ignore[arg-type]
                axis[3].lower() if len(axis) > 3 else "xyz",
                tuple(d.lower() for d in fields.get("dof", [])),
            )
        except (KeyError, IndexError, ValueError) as exc:
            raise InputError(f"{name}: a bone lacks a name, direction or length ({exc})") from exc
        bones[bone.name] = bone
    parent: dict[str, str] = {}
    for line in _section(text, "hierarchy").splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0] not in ("begin", "end"):
            for child in parts[1:]:
                parent[child] = parts[0]
    order: list[str] = []
    pending = [b for b in bones if b in parent]
    placed = {"root"}
    while pending:
        ready = [b for b in pending if parent[b] in placed]
        if not ready:
            raise InputError(f"{name}: the hierarchy does not reach {sorted(pending)} from root")
        for b in ready:
            order.append(b)
            placed.add(b)
            pending.remove(b)
    missing = sorted((set(COCO_FROM_START.values()) | {"head"}) - set(order))
    if missing:
        raise InputError(f"{name}: the skeleton lacks the bones {missing}")
    return Skeleton(bones, parent, root_order, root_axis, unit_m, tuple(order))  # type: ignore[arg-type]


@dataclass(frozen=True, slots=True)
class Motion:
    """AMC motion: per channel name (``root`` or a bone) its (T, k) values in dof order."""

    values: dict[str, F64]

    def __len__(self) -> int:
        return len(self.values["root"])


def parse_amc(text: str, skeleton: Skeleton, name: str = "amc") -> Motion:
    """Parse an AMC motion file against its skeleton."""
    frames: list[dict[str, list[float]]] = []
    cur: dict[str, list[float]] | None = None
    for raw in text.replace("\r", "").splitlines():
        line = raw.strip()
        if not line or line.startswith("#") or line.startswith(":"):
            continue
        if line.isdigit():
            cur = {}
            frames.append(cur)
            continue
        if cur is None:
            raise InputError(f"{name}: values before the first frame number")
        parts = line.split()
        try:
            cur[parts[0]] = [float(v) for v in parts[1:]]
        except ValueError as exc:
            raise InputError(f"{name}: bad number in {line!r}") from exc
    if len(frames) < 2:
        raise InputError(f"{name}: not an AMC file (fewer than 2 frames)")
    values: dict[str, F64] = {}
    channels = {"root": len(skeleton.root_order)} | {b: len(skeleton.bones[b].dof) for b in skeleton.order}
    for ch, width in channels.items():
        if width == 0:
            continue
        rows = [f.get(ch, [0.0] * width) for f in frames]
        if any(len(r) != width for r in rows):
            raise InputError(f"{name}: {ch} needs {width} values per frame")
        values[ch] = np.asarray(rows, dtype=np.float64)
    if "root" not in values:
        raise InputError(f"{name}: no root values")
    return Motion(values)


@dataclass(frozen=True, slots=True)
class Posed:
    """COCO-17 joints (T, 17, 3), foot points (T, 6, 3) and pelvis (T, 3), CAVE axes, metres."""

    joints: F64
    foot_points: F64
    pelvis: F64


def _axis_matrix(angles: tuple[float, float, float], order: str) -> F64:
    vals = {ax: np.array([a]) for ax, a in zip("xyz", angles, strict=True)}
    m = np.eye(3)
    for ax in order:  # the ASF's axis order: rotations applied in that order (first = innermost)
        m = axis_rotations(ax, vals[ax])[0] @ m
    return m


def forward_kinematics(skeleton: Skeleton, motion: Motion) -> Posed:
    """World positions of the bones over the motion, mapped to COCO-17 in CAVE axes."""
    n = len(motion)
    root_vals = motion.values["root"]
    tr = {c: root_vals[:, i] for i, c in enumerate(skeleton.root_order)}
    pos0 = np.stack([tr.get("tx", np.zeros(n)), tr.get("ty", np.zeros(n)), tr.get("tz", np.zeros(n))], -1)
    pos0 = pos0 * skeleton.unit_m
    c_root = _axis_matrix(skeleton.root_axis, "xyz")
    rot = _euler({c[1]: tr[c] for c in ("rx", "ry", "rz") if c in tr}, n)
    world_r = {"root": c_root @ rot @ c_root.T}
    start: dict[str, F64] = {}
    end: dict[str, F64] = {"root": pos0}
    for b in skeleton.order:
        bone = skeleton.bones[b]
        c = _axis_matrix(bone.axis_deg, bone.axis_order)
        vals = motion.values.get(b)
        m = _euler({d[1]: vals[:, i] for i, d in enumerate(bone.dof)} if vals is not None else {}, n)
        world_r[b] = world_r[skeleton.parent[b]] @ c @ m @ c.T
        start[b] = end[skeleton.parent[b]]
        end[b] = start[b] + bone.length_m * (world_r[b] @ np.asarray(bone.direction))
    out = np.full((n, NUM_JOINTS, 3), np.nan)
    for coco, b in COCO_FROM_START.items():
        out[:, J[coco]] = start[b]
    head_mid = 0.5 * (start["head"] + end["head"])
    up = end["head"] - start["head"]
    up /= np.maximum(np.linalg.norm(up, axis=-1, keepdims=True), 1e-9)
    fwd = world_r["head"] @ np.array([0.0, 0.0, 1.0])
    left = world_r["head"] @ np.array([1.0, 0.0, 0.0])
    for coco, (f, u, s) in FACE.items():
        out[:, J[coco]] = head_mid + f * fwd + u * up + s * left
    feet = np.stack([end[b] for b in FOOT_ENDS if b in end] + [start["lfoot"], start["rfoot"]], axis=1)
    return Posed(out @ SRC_TO_CAVE.T, feet @ SRC_TO_CAVE.T, pos0 @ SRC_TO_CAVE.T)
