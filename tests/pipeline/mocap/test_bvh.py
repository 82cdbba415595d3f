"""The BVH reader (pipeline.mocap.bvh) on small files written here, whose joint positions follow
from the format's rules by hand, and on the committed real clips (pipeline/mocap/vendored/)."""

from __future__ import annotations

import re

import numpy as np
import pytest

from pipeline.errors import InputError
from pipeline.mocap import bvh
from pipeline.mocap.fetch import PACKAGES, convert_bvh, load_catalogue, vendored_members
from pipeline.skeleton import J, SkeletonSequence

# A humanoid in the Mixamo convention: +Y up, facing +Z, the person's left at +X; centimetres.
# Hips 85 above the floor, ankles 5, toes at the floor 12 ahead, the head's top at 159.
LEG = """JOINT {side}UpLeg
{{
OFFSET {x} 0 0
CHANNELS 3 Zrotation Xrotation Yrotation
JOINT {side}Leg
{{
OFFSET 0 -40 0
CHANNELS 3 Zrotation Xrotation Yrotation
JOINT {side}Foot
{{
OFFSET 0 -40 0
CHANNELS 3 Zrotation Xrotation Yrotation
JOINT {side}ToeBase
{{
OFFSET 0 -5 12
CHANNELS 3 Zrotation Xrotation Yrotation
End Site
{{
OFFSET 0 0 4
}}
}}
}}
}}
}}
"""
ARM = """JOINT {side}Arm
{{
OFFSET {x} 35 0
CHANNELS 3 Zrotation Xrotation Yrotation
JOINT {side}ForeArm
{{
OFFSET {x2} 0 0
CHANNELS 3 Zrotation Xrotation Yrotation
JOINT {side}Hand
{{
OFFSET {x2} 0 0
CHANNELS 3 Zrotation Xrotation Yrotation
End Site
{{
OFFSET 5 0 0
}}
}}
}}
}}
"""
CHANNELS_PER_FRAME = 6 + 3 * (4 + 4 + 1 + 1 + 1 + 3 + 3)


def humanoid(frames: list[list[float]], mirror: bool = False) -> str:
    """The humanoid BVH with ``frames`` (each CHANNELS_PER_FRAME values; zeros = standing at rest);
    ``mirror``: the left joints at -X (a mirrored file)."""
    s = -1 if mirror else 1
    legs = LEG.format(side="Left", x=10 * s) + LEG.format(side="Right", x=-10 * s)
    arms = ARM.format(side="Left", x=18 * s, x2=26 * s) + ARM.format(side="Right", x=-18 * s, x2=-26 * s)
    spine = (
        "JOINT Spine\n{\nOFFSET 0 10 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
        "JOINT Neck\n{\nOFFSET 0 40 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
        "JOINT Head\n{\nOFFSET 0 8 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
        "End Site\n{\nOFFSET 0 16 0\n}\n}\n}\n" + arms + "}\n"
    )
    head = (
        "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\n"
        "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n" + legs + spine + "}\n"
    )
    return with_motion(head, frames)


def rest(**channels: float) -> list[float]:
    """One frame standing at rest (hips 85 up), with some channels set: ``name_axis=deg``."""
    f = [0.0] * CHANNELS_PER_FRAME
    f[1] = 85.0
    parsed = bvh.parse_bvh(humanoid([f, f]))
    col = 0
    where: dict[str, int] = {}
    for j in parsed.joints:
        for c in j.channels:
            where[f"{j.name}_{c[0].lower()}{'pos' if c.endswith('position') else ''}"] = col
            col += 1
    for key, value in channels.items():
        f[where[key]] = value
    return f


def test_forward_kinematics_follows_the_channel_order() -> None:
    """Channels ``Zrotation Xrotation Yrotation`` make R = Rz Rx Ry: with Z = X = 90 deg the thigh
    (0, -40, 0) turns to (0, 0, -40); the other order, Rx Rz, would give (40, 0, 0)."""
    clip = bvh.parse_bvh(humanoid([rest(), rest(LeftUpLeg_z=90.0, LeftUpLeg_x=90.0)]))
    origin, _, end = bvh.world(clip)
    hip, knee = clip.index("LeftUpLeg"), clip.index("LeftLeg")
    assert hip is not None and knee is not None
    np.testing.assert_allclose(origin[0, hip], [10, 85, 0], atol=1e-9)
    np.testing.assert_allclose(origin[0, knee], [10, 45, 0], atol=1e-9)
    np.testing.assert_allclose(origin[1, knee] - origin[1, hip], [0, 0, -40], atol=1e-9)
    head = clip.index("Head")
    assert head is not None
    np.testing.assert_allclose(end[0, head], [0, 159, 0], atol=1e-9)  # the End Site
    # the root's rotation turns everything below it: Ry(90) takes the left hip (10, 0, 0) to (0, 0, -10)
    turned = bvh.world(bvh.parse_bvh(humanoid([rest(), rest(Hips_y=90.0)])))[0]
    np.testing.assert_allclose(turned[1, hip], [0, 85, -10], atol=1e-9)


def test_a_namespace_prefix_on_the_joint_names_is_the_same_skeleton() -> None:
    """FBX-to-BVH exports name joints ``mixamorig:LeftUpLeg``: the same person, joint for joint."""
    plain = humanoid([rest(), rest(LeftUpLeg_x=30.0)])
    prefixed = re.sub(r"(ROOT|JOINT) (\w+)", r"\1 mixamorig:\2", plain)
    assert "JOINT mixamorig:LeftUpLeg" in prefixed
    a, b = (bvh.to_cave(bvh.parse_bvh(text), 1.70).joints for text in (plain, prefixed))
    np.testing.assert_allclose(a, b)


ROT = "CHANNELS 3 Zrotation Xrotation Yrotation"
EYES = "".join(
    f"JOINT {side}Eye\n{{\nOFFSET {x} 6 8\n{ROT}\nEnd Site\n{{\nOFFSET 0 0 1\n}}\n}}\n"
    for side, x in (("left", 3), ("right", -3))
)
TOE_JOINT = re.compile(  # the humanoid's toe joint, with its End Site
    r"JOINT (Left|Right)ToeBase\n\{\nOFFSET 0 -5 12\n[^\n]*\nEnd Site\n\{\nOFFSET 0 0 4\n\}\n\}\n"
)


def with_motion(hierarchy: str, frames: list[list[float]] | int = 2) -> str:
    """A hierarchy (the text before MOTION) with ``frames`` (each joint's values in the hierarchy's
    channel order; an int: that many frames of zeros)."""
    if isinstance(frames, int):
        width = sum(int(n) for n in re.findall(r"CHANNELS (\d+)", hierarchy))
        frames = [[0.0] * width] * frames
    rows = "\n".join(" ".join(f"{v:g}" for v in f) for f in frames)
    return f"{hierarchy}MOTION\nFrames: {len(frames)}\nFrame Time: 0.0333333\n{rows}\n"


def _block_end(text: str, start: int) -> int:
    """Where the block that opens after ``start`` closes (just past its brace)."""
    depth, i = 0, text.index("{", start)
    while True:
        depth += {"{": 1, "}": -1}.get(text[i], 0)
        i += 1
        if depth == 0:
            return i


def renamed(text: str, names: dict[str, str], toe: bool = True, eyes: bool = False,
            collar: str | None = None) -> str:
    """The humanoid ``text`` written as another exporter writes it: ``names`` maps its joint names
    (``LeftUpLeg``, ``Head``, ...) to others; ``toe`` False: no toe joint (the foot ends in an End
    Site where the toe was); ``eyes``: the head ends in two eye joints instead of an End Site;
    ``collar``: a collarbone joint between the spine and each arm (``{side}`` in it: Left / Right,
    ``{s}``: L / R), as Xsens and OptiTrack write them. Each joint's values are carried over by name."""
    clip = bvh.parse_bvh(text)
    head = text.split("MOTION")[0]
    if not toe:
        head = TOE_JOINT.sub("End Site\n{\nOFFSET 0 -5 12\n}\n", head)
    if eyes:
        head = head.replace("End Site\n{\nOFFSET 0 16 0\n}\n", EYES)
    if collar:
        for side, sign in (("Left", 1), ("Right", -1)):
            at = head.index(f"JOINT {side}Arm\n")
            end = _block_end(head, at)
            arm = head[at:end].replace(f"OFFSET {18 * sign} 35 0", f"OFFSET {10 * sign} 0 0", 1)
            bone = collar.format(side=side, s=side[0])
            head = head[:at] + f"JOINT {bone}\n{{\nOFFSET {8 * sign} 35 0\n{ROT}\n{arm}\n}}" + head[end:]
    for old, new in names.items():
        head = re.sub(rf"(ROOT|JOINT) {old}\n", rf"\1 {new}\n", head)
    back = {new: old for old, new in names.items()}
    out = bvh.parse_bvh(with_motion(head))
    col = {}
    for j in clip.joints:
        for c in j.channels:
            col[(j.name, c)] = len(col)
    keys = [(back.get(j.name, j.name), c) for j in out.joints for c in j.channels]  # a new joint: zeros
    return with_motion(head, [[frame[col[k]] if k in col else 0.0 for k in keys] for frame in clip.values])


def sided(parts: dict[str, str]) -> dict[str, str]:
    """Both sides' names from one pattern per part: ``{side}`` Left / Right, ``{s}`` L / R,
    ``{l}`` l / r."""
    return {f"{side}{part}": name.format(side=side, s=side[0], l=side[0].lower())
            for side in ("Left", "Right") for part, name in parts.items()}


def as_poser(text: str) -> str:
    """The same person in Poser / DAZ naming (``hip``, ``lThigh``, ``lShin``, ``lFoot``, ``lShldr``,
    ``head``): no toe joint (the foot ends in an End Site where the toe was), a head that ends in two
    eye joints instead of an End Site."""
    names = sided({"UpLeg": "{l}Thigh", "Leg": "{l}Shin", "Foot": "{l}Foot", "Arm": "{l}Shldr",
                   "ForeArm": "{l}ForeArm", "Hand": "{l}Hand"})
    out = renamed(text, names | {"Hips": "hip", "Spine": "abdomen", "Neck": "neck", "Head": "head"},
                  toe=False, eyes=True)
    poser = bvh.parse_bvh(out)
    assert poser.index("lToeBase", "LeftToeBase", "lToe") is None and poser.index("leftEye") is not None
    return out


# How other exporters name the humanoid's joints (each with a toe joint and a head End Site)
NAMINGS = {
    "xsens-mvn": (sided({"UpLeg": "{side}UpperLeg", "Leg": "{side}LowerLeg", "ToeBase": "{side}Toe",
                         "Arm": "{side}UpperArm"}), "{side}Shoulder"),
    "unity": (sided({"UpLeg": "{side}UpperLeg", "Leg": "{side}LowerLeg", "ToeBase": "{side}Toes",
                     "Arm": "{side}UpperArm", "ForeArm": "{side}LowerArm"}), None),
    "optitrack-motive": (sided({"UpLeg": "{s}Thigh", "Leg": "{s}Shin", "Foot": "{s}Foot", "ToeBase": "{s}Toe",
                                "Arm": "{s}UArm", "ForeArm": "{s}FArm", "Hand": "{s}Hand"}), "{s}Shoulder"),
    "bandai-namco": (sided({"UpLeg": "UpperLeg_{s}", "Leg": "LowerLeg_{s}", "Foot": "Foot_{s}",
                            "ToeBase": "Toes_{s}", "Arm": "UpperArm_{s}", "ForeArm": "LowerArm_{s}",
                            "Hand": "Hand_{s}"}), "Shoulder_{s}"),
    "blender-rigify": (sided({"UpLeg": "thigh.{s}", "Leg": "shin.{s}", "Foot": "foot.{s}",
                              "ToeBase": "toe.{s}", "Arm": "upper_arm.{s}", "ForeArm": "forearm.{s}",
                              "Hand": "hand.{s}"})
                       | {"Head": "head"}, "shoulder.{s}"),
    "3dsmax-biped": (sided({"UpLeg": "Bip01 {s} Thigh", "Leg": "Bip01 {s} Calf", "Foot": "Bip001_{s}_Foot",
                            "ToeBase": "Bip01 {s} Toe0", "Arm": "Bip01 {s} UpperArm",
                            "ForeArm": "Bip01 {s} Forearm", "Hand": "Bip01 {s} Hand"})
                     | {"Hips": "Bip01 Pelvis", "Head": "Bip01 Head"}, "Bip01 {s} Clavicle"),
}


@pytest.mark.parametrize("naming", sorted(NAMINGS))
def test_other_exporters_names_are_the_same_person(naming: str) -> None:
    """Xsens MVN, Unity, OptiTrack Motive, Bandai Namco-style, Blender Rigify and 3ds Max Biped
    names (Biped's with spaces, or underscores and Max's Bip001): the same motion gives the same
    joints; where a collarbone is named like a shoulder (Xsens' LeftShoulder, Motive's LShoulder),
    the shoulder is the upper arm's joint, not the collarbone's."""
    frames = [rest(), rest(Hips_y=40.0, LeftUpLeg_x=-30.0, LeftLeg_x=40.0, RightArm_z=-50.0),
              rest(Hips_xpos=20.0, Neck_y=30.0, LeftForeArm_y=60.0)]
    plain = humanoid(frames)
    names, collar = NAMINGS[naming]
    other = renamed(plain, names, collar=collar)
    assert "LeftUpLeg" not in other and (collar is None or collar.format(side="Left", s="L") in other)
    a = bvh.to_cave(bvh.parse_bvh(plain), 1.70).joints
    b = bvh.to_cave(bvh.parse_bvh(other), 1.70).joints
    np.testing.assert_allclose(b, a, rtol=0, atol=1e-9)


def test_a_poser_named_skeleton_is_the_same_person() -> None:
    """Poser, DAZ and CMU's Daz-friendly BVH files name the joints ``hip`` / ``lThigh`` / ``lShin`` /
    ``lFoot`` / ``lShldr``, end the foot in an End Site (no toe joint) and the head in eye joints:
    the same motion gives the same joints (the head's top, which sets the scale, is estimated there:
    within 2 %), a face in front of the head."""
    frames = [rest(), rest(Hips_y=40.0, LeftUpLeg_x=-30.0, LeftLeg_x=40.0), rest(Hips_xpos=20.0, Neck_y=30.0)]
    plain = humanoid(frames)
    a = bvh.to_cave(bvh.parse_bvh(plain), 1.70).joints
    b = bvh.to_cave(bvh.parse_bvh(as_poser(plain)), 1.70).joints
    body = [J[k] for k in bvh.NAMES]
    np.testing.assert_allclose(b[:, body], a[:, body], rtol=0, atol=0.02 * 1.70)
    np.testing.assert_allclose(b[:, :5], a[:, :5], rtol=0, atol=0.03)  # the face: nose, eyes, ears


def test_the_face_looks_where_the_head_looks_whatever_the_first_frame() -> None:
    """The face turns with the head from the skeleton's rest pose (toes forward): a clip whose first
    frame is turned 90 degrees (CMU 131_03 starts so) still has the nose in front of the ears in every
    frame; the face was once turned from frame 0, which put it over an ear for the rest of such a clip."""
    clip = bvh.parse_bvh(humanoid([rest(Hips_y=90.0), rest(), rest(Hips_y=-60.0), rest(Head_y=45.0)]))
    j = bvh.to_cave(clip, 1.70).joints
    across = j[:, J["l_hip"], :2] - j[:, J["r_hip"], :2]
    body_fwd = np.stack([across[:, 1], -across[:, 0]], axis=1)  # the left hip's side turned to forward
    face = j[:, J["nose"], :2] - 0.5 * (j[:, J["l_ear"], :2] + j[:, J["r_ear"], :2])
    cos = np.einsum("ti,ti->t", body_fwd, face) / np.linalg.norm(body_fwd, axis=1)
    cos /= np.linalg.norm(face, axis=1)
    np.testing.assert_allclose(cos[:3], 1.0, atol=1e-6)
    np.testing.assert_allclose(cos[3], np.cos(np.radians(45.0)), atol=1e-6)  # the head turned on its own


def test_to_cave_finds_up_forward_left_and_the_scale() -> None:
    clip = bvh.parse_bvh(humanoid([rest(), rest(Hips_xpos=30.0)]))
    posed = bvh.to_cave(clip, 1.70, "synthetic")
    scale = 1.70 * 0.96 / 159.0  # the head's top 159 above the toes, the soles 4 % of the height lower
    j = posed.joints[0]
    np.testing.assert_allclose(j[J["l_hip"]], [-10 * scale, 0, 85 * scale], atol=1e-9)  # left = -X
    np.testing.assert_allclose(j[J["r_ankle"]], [10 * scale, 0, 5 * scale], atol=1e-9)
    np.testing.assert_allclose(j[J["l_wrist"]], [-70 * scale, 0, 130 * scale], atol=1e-9)
    assert j[J["nose"], 1] > 0 and j[J["nose"], 2] > j[J["l_shoulder"], 2]  # the face forward, above
    assert j[J["l_eye"], 0] < j[J["r_eye"], 0] and j[J["l_ear"], 0] < j[J["r_ear"], 0]
    # the file's +X (the person's left) is CAVE -X: moving the hips 30 to +X moves them 30 to the left
    np.testing.assert_allclose(posed.pelvis[1] - posed.pelvis[0], [-30 * scale, 0, 0], atol=1e-9)
    assert posed.foot_points.shape == (2, 4, 3)


def test_bad_bvh_input_is_one_clear_error() -> None:
    good = humanoid([rest(), rest()])
    with pytest.raises(InputError, match="not a BVH file"):
        bvh.parse_bvh("hello", "x.bvh")
    with pytest.raises(InputError, match="motion values"):
        bvh.parse_bvh(good.rsplit("\n", 2)[0], "x.bvh")  # the last frame cut off
    with pytest.raises(InputError, match="unknown channels"):
        bvh.parse_bvh(good.replace("Zrotation Xrotation Yrotation", "Zrotation Xrotation Wrotation", 1))
    with pytest.raises(InputError, match="mirrored"):
        bvh.to_cave(bvh.parse_bvh(humanoid([rest(), rest()], mirror=True)), 1.70)
    with pytest.raises(InputError, match="Frame Time is not a number"):
        bvh.parse_bvh(good.replace("Frame Time: 0.0333333", "Frame Time: 0.03.3"))
    site = "End Site\n{\nOFFSET 0 16 0\n"
    with pytest.raises(InputError, match="CHANNELS inside an End Site"):
        bvh.parse_bvh(good.replace(site, site + "CHANNELS 1 Xrotation\n"))
    no_head = bvh.parse_bvh(good.replace("JOINT Head", "JOINT Skull"))
    with pytest.raises(InputError, match="no joint named Head"):
        bvh.to_cave(no_head, 1.70)
    no_toe = with_motion(TOE_JOINT.sub("", good.split("MOTION")[0], count=1))  # the left foot ends nowhere
    with pytest.raises(InputError, match=r"no joint named LeftToeBase or LeftToe.*no End Site"):
        bvh.to_cave(bvh.parse_bvh(no_toe), 1.70)
    with pytest.raises(InputError, match="height_m"):
        bvh.to_cave(bvh.parse_bvh(good), 3.0)


def _vendored_people(package: str) -> dict[str, SkeletonSequence]:
    """A vendored package's clips converted, each checked to be a 1.70 m person at 30 fps, every joint
    known, left on the left (the left hip lies to the left of where the face points: CAVE's left of
    forward turns counter-clockwise)."""
    specs = [c for c in load_catalogue() if c.package == package]
    files = vendored_members(PACKAGES[package], sorted(c.path for c in specs))
    out = {}
    for spec in specs:
        seq = convert_bvh(files[spec.path].decode("latin-1"), spec)
        j = seq.joints_m
        assert seq.fps == 30.0 and np.isfinite(j).all(), spec.id
        assert 1.55 < np.percentile(j[:, J["nose"], 2], 90) < 1.70, spec.id
        across = j[:, J["l_hip"], :2] - j[:, J["r_hip"], :2]
        facing = j[:, J["nose"], :2] - 0.5 * (j[:, J["l_ear"], :2] + j[:, J["r_ear"], :2])
        assert np.median(facing[:, 0] * across[:, 1] - facing[:, 1] * across[:, 0]) > 0, spec.id
        out[spec.id] = seq
    return out


def test_the_committed_real_clips_convert_to_standing_people() -> None:
    """Each of AnimatedDrawings' clips (two skeletons, +Z up and +Y up) becomes a 1.70 m person on
    the floor, upright, left on the left; the wave keeps both feet planted; the zombie walk goes
    7 m and labels its steps forward."""
    clips = _vendored_people("animated-drawings")
    assert set(clips) == {"ad-wave-hello", "ad-dab", "ad-jumping", "ad-zombie", "ad-cmu-jumping-jacks"}
    for name, seq in clips.items():
        j = seq.joints_m
        ankles = j[:, [J["l_ankle"], J["r_ankle"]], 2]
        assert 0.03 < np.percentile(ankles, 5) < 0.12, name
        if name == "ad-wave-hello":
            assert set(seq.labels or ()) == {"still"} and np.ptp(ankles) < 0.02
        if name == "ad-zombie":
            travel = np.ptp(0.5 * (j[:, J["l_hip"], :2] + j[:, J["r_hip"], :2]), axis=0).max()
            labels = np.asarray(seq.labels)
            assert 6.5 < travel < 7.5 and 0.6 < np.mean(labels == "forward") < 0.9
            assert "turn" in (seq.tags or ())


def test_the_committed_cmu_131_clips_convert_to_people_who_walk_and_stand() -> None:
    """bvh11's three CMU subject-131 clips (the cgspeed conversion's skeleton, +Y up, inches) become
    1.70 m people on the floor, left on the left; each begins and ends standing still; the two walks
    carry forward labels over 1.7-2.7 m of travel, and the hops are ignored, never scored."""
    clips = _vendored_people("bvh11")
    assert set(clips) == {"cmu-131-01-walk-stop", "cmu-131-02-walk-stop", "cmu-131-03-hop-stop"}
    for name, seq in clips.items():
        j = seq.joints_m
        labels = np.asarray(seq.labels)
        assert labels[0] == labels[-1] == "still", name
        walking = labels == "forward"
        if name == "cmu-131-03-hop-stop":
            assert not walking.any() and "hop" in (seq.tags or ())
        else:
            pelvis = 0.5 * (j[walking, J["l_hip"], :2] + j[walking, J["r_hip"], :2])
            assert 1.2 < np.linalg.norm(pelvis[-1] - pelvis[0]) < 3.0, name


def test_the_committed_cmu_13_29_take_converts_to_a_person_exercising_on_the_spot() -> None:
    """The CMU 13_29 take (cgspeed MotionBuilder skeleton, 38 s at 120 Hz) becomes a 1.70 m person
    who stays within 0.5 m of one place, squats with the pelvis below 0.4 m, and is labelled still
    throughout but for its first frame (the conversion's rest pose) and the knee raises (ignored)."""
    (seq,) = _vendored_people("monoform-previs-studio").values()
    j = seq.joints_m
    assert 1140 < len(j) < 1160
    pelvis = 0.5 * (j[:, J["l_hip"]] + j[:, J["r_hip"]])
    assert np.ptp(pelvis[:, :2], axis=0).max() < 0.5 and pelvis[:, 2].min() < 0.4
    labels, tags = np.asarray(seq.labels), np.asarray(seq.tags)
    assert set(labels) == {"still", "ignore"} and set(tags[labels == "ignore"]) == {"start", "knee-raise"}
