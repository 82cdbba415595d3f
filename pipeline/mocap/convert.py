"""A lab's own motion capture as SPEC skeleton NPZs: ``cavewalk data convert``.

A BVH file (joint names as MotionBuilder-style exports write them: ``LeftUpLeg``, ``LeftLeg``,
``LeftFoot``, ``LeftToeBase``, ``LeftArm``, ``Head``, ..., with or without a ``namespace:`` prefix; or
the CMU conversion's ``LeftHip``, ``LeftKnee``, ``LeftAnkle``; Xsens, Unity, OptiTrack, Poser /
DAZ / Second Life, Bandai Namco-style, Blender Rigify or 3ds Max Biped names: :mod:`pipeline.mocap.bvh`;
scaled to the person's height, which BVH files do not carry), an ASF/AMC pair
(:mod:`pipeline.mocap.acclaim`, in the ASF's own units) or a C3D trial that holds joint centres
(Vicon Plug-in Gait's model outputs or a lab's joint-centre points: :mod:`pipeline.mocap.markers`,
in the file's units; markers alone cannot place a skeleton) becomes the joints the
recogniser sees, at 30 fps, on the floor, with the feet's contacts; labelled, if asked, by one
label for the whole clip or by the bout rule (the label from the first lift-off to the last
touch-down, ``still`` before and after: :mod:`pipeline.mocap.labels`), so that ``cavewalk
evaluate`` can score the recogniser on it. The same converters make the catalogue's clips.

API::

    seq = convert_file(ConvertRequest(Path("walk.bvh"), LabelRule("bout", "forward"), height_m=1.82))
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from pipeline.errors import DataError, InputError
from pipeline.mocap.c3d import read_c3d
from pipeline.mocap.fetch import (
    BVH_HEIGHT_M,
    ClipSpec,
    convert_acclaim,
    convert_bvh,
    convert_c3d,
    convert_c3d_jc,
)
from pipeline.mocap.labels import LabelRule
from pipeline.mocap.markers import JC_POINTS, JOINT_POINTS
from pipeline.skeleton import SkeletonSequence

FILE_FORMATS = {".bvh": "bvh", ".amc": "acclaim", ".c3d": "c3d"}  # by file name ending
# the leg joint centres a C3D file must hold: Vicon Plug-in Gait's model outputs, or a lab's own
PIG_LEGS = tuple(JOINT_POINTS[j][0] for j in ("l_hip", "r_hip", "l_knee", "r_knee", "l_ankle", "r_ankle"))
JC_LEGS = tuple(JC_POINTS.values())


@dataclass(frozen=True, slots=True)
class ConvertRequest:
    """One file to convert. rule: how to label it (None: no labels). skeleton: the ASF file of an
    AMC motion. height_m: the person's height, for a BVH file (None: :data:`BVH_HEIGHT_M`; an ASF/AMC
    pair keeps its own units, so a height given for one is an error)."""

    path: Path
    rule: LabelRule | None = None
    skeleton: Path | None = None
    height_m: float | None = None


def _text(path: Path, what: str) -> str:
    if path.is_dir():
        raise InputError(f"{path} is a folder, not a {what} file")
    if not path.is_file():
        raise InputError(f"{what} file not found: {path}")
    return path.read_bytes().decode("latin-1")  # BVH / ASF / AMC are ASCII; never fails


def convert_file(req: ConvertRequest) -> SkeletonSequence:
    """The file as a skeleton sequence (``source`` = its name without the ending); one
    :class:`InputError` for a file that is not what its ending says, an AMC without its ASF, or a
    height outside (0.5, 2.5) m."""
    fmt = FILE_FORMATS.get(req.path.suffix.lower())
    if fmt is None:
        raise InputError(
            f"{req.path}: cannot convert a {req.path.suffix or 'nameless'} file; give a BVH (.bvh), an "
            f"AMC motion (.amc) with its ASF skeleton (--skeleton) or a C3D trial (.c3d)"
        )
    if fmt == "acclaim" and req.skeleton is None:
        raise InputError(f"{req.path}: an AMC motion needs its ASF skeleton (--skeleton FILE.asf)")
    if fmt == "bvh" and req.skeleton is not None:
        raise InputError(f"{req.path}: a BVH file carries its own skeleton; --skeleton is for AMC files")
    if fmt != "bvh" and req.height_m is not None:
        raise InputError(f"{req.path}: {'an ASF/AMC pair' if fmt == 'acclaim' else 'a C3D file'} keeps "
                         "its own units; --height-m is for BVH files")
    if fmt == "c3d" and req.skeleton is not None:
        raise InputError(f"{req.path}: a C3D file carries its own points; --skeleton is for AMC files")
    rule = req.rule or LabelRule("still")
    spec = ClipSpec(req.path.stem, "", str(req.path), "c3d-pig" if fmt == "c3d" else fmt, "", rule, "eval",
                    "", skeleton=str(req.skeleton or ""))  # a C3D's format is settled by its points
    text = _text(req.path, {"bvh": "BVH", "acclaim": "AMC", "c3d": "C3D"}[fmt])  # latin-1: every byte back
    asf = _text(req.skeleton, "ASF") if req.skeleton is not None else ""
    try:
        if fmt == "bvh":
            seq = convert_bvh(text, spec, height_m=BVH_HEIGHT_M if req.height_m is None else req.height_m)
        elif fmt == "c3d":
            seq = _convert_c3d(text.encode("latin-1"), spec)
        else:
            seq = convert_acclaim(asf, text, spec)
    except (InputError, DataError):
        raise
    except (ValueError, IndexError, KeyError) as exc:  # a malformed file the readers did not name
        raise InputError(f"{req.path}: not a readable {fmt.upper()} file ({exc})") from exc
    if len(seq.joints_m) < 2:
        raise InputError(f"{req.path}: the motion has fewer than 2 frames at 30 fps")
    return seq if req.rule is not None else replace(seq, labels=None, tags=None)


def _convert_c3d(data: bytes, spec: ClipSpec) -> SkeletonSequence:
    """A C3D trial by the joint centres it holds: Plug-in Gait's model outputs (``LFEP``, ``LFEO``,
    ``LTIO``, ...: :func:`pipeline.mocap.markers.pig_to_coco`) or a lab's joint-centre points
    (``LHJC``, ``LKJC``, ``LAJC``, ...: :func:`~pipeline.mocap.markers.jc_to_coco`). A file of markers
    alone is one error: the joints cannot be placed without a biomechanical model."""
    labels = set(read_c3d(data, spec.id).labels)
    if all(n in labels for n in PIG_LEGS):
        return convert_c3d(data, spec)
    if all(n in labels for n in JC_LEGS):
        return convert_c3d_jc(data, replace(spec, format="c3d-jc"))
    shown = ", ".join(sorted(labels)[:8]) + (", ..." if len(labels) > 8 else "")
    raise InputError(
        f"{spec.id}: no joint centres to place the skeleton on: a C3D file needs Plug-in Gait's model "
        f"outputs ({', '.join(PIG_LEGS)}; run the Plug-in Gait model before exporting) or joint-centre "
        f"points ({', '.join(JC_LEGS)}); it has {len(labels)} points ({shown})"
    )
