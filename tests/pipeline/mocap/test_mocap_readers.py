"""The C3D reader, the Plug-in Gait mapping and the ASF/AMC kinematics on files written here."""

from __future__ import annotations

import json
import struct
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import InputError
from pipeline.mocap import acclaim
from pipeline.mocap.c3d import read_c3d
from pipeline.mocap.convert import ConvertRequest, convert_file
from pipeline.mocap.fetch import belt_velocity, load_catalogue
from pipeline.mocap.labels import LabelRule
from pipeline.mocap.landmarks import read_landmarks
from pipeline.mocap.markers import pig_to_coco
from pipeline.skeleton import J


def _param(gid: int, name: str, kind: int, dims: list[int], data: bytes) -> bytes:
    body = struct.pack("<bB", kind, len(dims)) + bytes(dims) + data + b"\x00"
    return struct.pack("<bb", len(name), gid) + name.encode() + struct.pack("<h", len(body) + 2) + body


def _group(gid: int, name: str) -> bytes:
    return struct.pack("<bb", len(name), -gid) + name.encode() + struct.pack("<h", 3) + b"\x00"


def write_c3d(
    labels: list[str],
    xyz: np.ndarray,
    rate: float,
    as_float: bool,
    invalid: set[tuple[int, int]],
    units: str = "mm",
) -> bytes:
    """A minimal Intel C3D file: header, POINT group, one data section (no analog)."""
    n_frames, n_points = xyz.shape[:2]
    scale = -1.0 if as_float else 0.1
    width = max(len(s) for s in labels)
    lab = b"".join(s.ljust(width).encode() for s in labels)
    params = _group(1, "POINT")
    params += _param(1, "USED", 2, [], struct.pack("<h", n_points))
    params += _param(1, "SCALE", 4, [], struct.pack("<f", scale))
    params += _param(1, "RATE", 4, [], struct.pack("<f", rate))
    params += _param(1, "DATA_START", 2, [], struct.pack("<h", 3))
    params += _param(1, "UNITS", -1, [len(units)], units.encode())
    params += _param(1, "LABELS", -1, [width, n_points], lab)
    params += b"\x00\x00"
    psec = (bytes([1, 80, 1, 84]) + params).ljust(512, b"\x00")
    header = struct.pack("<BBhhhhh", 2, 0x50, n_points, 0, 1, n_frames, 0)
    header += struct.pack("<f", scale) + struct.pack("<hh", 3, 0) + struct.pack("<f", rate)
    rows = []
    for t in range(n_frames):
        for p in range(n_points):
            bad = (t, p) in invalid
            if as_float:
                rows.append(struct.pack("<4f", *xyz[t, p], -1.0 if bad else 0.0))
            else:
                rows.append(struct.pack("<4h", *np.round(xyz[t, p] / 0.1).astype(int), -1 if bad else 0))
    return header.ljust(512, b"\x00") + psec + b"".join(rows)


@pytest.mark.parametrize("as_float", [False, True])
def test_c3d_points_labels_rate_units_and_gaps(as_float: bool) -> None:
    rng = np.random.default_rng(0)
    xyz = np.round(rng.uniform(-1500, 1500, (7, 3, 3)), 1)
    data = write_c3d(["LASI", "RASI", "C7"], xyz, 100.0, as_float, {(2, 1)})
    pts = read_c3d(data)
    assert pts.labels == ("LASI", "RASI", "C7") and pts.rate_hz == 100.0 and pts.units == "mm"
    assert pts.points.shape == (7, 3, 3)
    got = pts.metres()
    assert np.isnan(got[2, 1]).all() and np.isfinite(np.delete(got.reshape(21, 3), 7, axis=0)).all()
    ok = ~np.isnan(got)
    assert np.allclose(got[ok], xyz[ok] / 1000, atol=1e-4)


def test_c3d_bad_bytes_are_one_clear_error() -> None:
    with pytest.raises(InputError, match="not a C3D file"):
        read_c3d(b"hello" * 200, "x.c3d")
    good = write_c3d(["A"], np.ones((3, 1, 3)), 50.0, False, set(), units="ft")
    with pytest.raises(InputError, match="units"):
        read_c3d(good).metres()


def test_plug_in_gait_mapping_puts_joints_where_the_model_outputs_are() -> None:
    names = [
        "LFEP",
        "RFEP",
        "LFEO",
        "RFEO",
        "LTIO",
        "RTIO",
        "LSHO",
        "RSHO",
        "LELB",
        "RELB",
        "LWRA",
        "LWRB",
        "RWRA",
        "LFHD",
        "RFHD",
        "LBHD",
        "RBHD",
        "LHEE",
        "RHEE",
        "PELO",
    ]
    pos = {  # mm, a person facing +Y, left at -X
        "LFEP": (-90, 0, 900),
        "RFEP": (90, 0, 900),
        "LFEO": (-90, 0, 500),
        "RFEO": (90, 0, 500),
        "LTIO": (-90, 0, 90),
        "RTIO": (90, 0, 90),
        "LSHO": (-180, 0, 1400),
        "RSHO": (180, 0, 1400),
        "LELB": (-200, 0, 1100),
        "RELB": (200, 0, 1100),
        "LWRA": (-200, 20, 850),
        "LWRB": (-200, -20, 850),
        "RWRA": (200, 20, 850),
        "LFHD": (-60, 80, 1600),
        "RFHD": (60, 80, 1600),
        "LBHD": (-60, -80, 1600),
        "RBHD": (60, -80, 1600),
        "LHEE": (-90, -40, 30),
        "RHEE": (90, -40, 30),
        "PELO": (0, 0, 950),
    }
    xyz = np.array([[pos[n] for n in names]] * 4, dtype=float)
    joints, feet, pelvis = pig_to_coco(read_c3d(write_c3d(names, xyz, 100.0, True, set())))
    assert joints.shape == (4, 17, 3) and np.isfinite(joints).all()
    assert np.allclose(joints[0, J["l_hip"]], [-0.09, 0, 0.9]) and np.allclose(
        joints[0, J["r_ankle"]], [0.09, 0, 0.09]
    )
    assert np.allclose(joints[0, J["l_wrist"]], [-0.2, 0, 0.85])  # the wrist bar's midpoint
    assert np.allclose(joints[0, J["r_wrist"]], [0.2, 0.02, 0.85])  # one marker: that marker
    nose, le, re_ = joints[0, J["nose"]], joints[0, J["l_ear"]], joints[0, J["r_ear"]]
    assert nose[1] > 0.08 and 1.5 < nose[2] < 1.6  # in front of the head band, a little lower
    assert le[0] < -0.07 and re_[0] > 0.07  # the left ear on the person's left
    assert np.allclose(pelvis[0], [0, 0, 0.95]) and feet.shape[1] == 4
    lower = [n for n in names if n[1:] in ("FEP", "FEO", "TIO", "HEE") or n == "PELO"]
    keep = [names.index(n) for n in lower]
    joints, _, _ = pig_to_coco(read_c3d(write_c3d(lower, xyz[:, keep], 100.0, True, set())))
    assert np.isnan(joints[:, [J["nose"], J["l_shoulder"], J["r_wrist"]]]).all()  # absent -> NaN
    assert np.isfinite(joints[:, [J["l_hip"], J["r_knee"], J["l_ankle"]]]).all()


ASF = """# test skeleton
:version 1.10
:name VICON
:units
  mass 1.0
  length 0.45
  angle deg
:root
   order TX TY TZ RX RY RZ
   axis XYZ
   position 0 0 0
   orientation 0 0 0
:bonedata
{bones}
:hierarchy
  begin
    root lhipjoint rhipjoint lowerback
    lhipjoint lfemur
    lfemur ltibia
    ltibia lfoot
    lfoot ltoes
    rhipjoint rfemur
    rfemur rtibia
    rtibia rfoot
    rfoot rtoes
    lowerback thorax
    thorax head lclavicle rclavicle
    lclavicle lhumerus
    lhumerus lradius
    lradius lwrist
    rclavicle rhumerus
    rhumerus rradius
    rradius rwrist
  end
"""
BONES = [  # name, direction, length (inches / 0.45), dof
    ("lhipjoint", "1 -1 0", 2.0, ""),
    ("lfemur", "0 -1 0", 7.0, "rx ry rz"),
    ("ltibia", "0 -1 0", 7.0, "rx"),
    ("lfoot", "0 0 1", 2.0, "rx rz"),
    ("ltoes", "0 0 1", 1.0, "rx"),
    ("rhipjoint", "-1 -1 0", 2.0, ""),
    ("rfemur", "0 -1 0", 7.0, "rx ry rz"),
    ("rtibia", "0 -1 0", 7.0, "rx"),
    ("rfoot", "0 0 1", 2.0, "rx rz"),
    ("rtoes", "0 0 1", 1.0, "rx"),
    ("lowerback", "0 1 0", 5.0, "rx ry rz"),
    ("thorax", "0 1 0", 5.0, "rx ry rz"),
    ("head", "0 1 0", 3.0, "rx ry rz"),
    ("lclavicle", "1 0 0", 3.0, ""),
    ("lhumerus", "0 -1 0", 5.0, "rx ry rz"),
    ("lradius", "0 -1 0", 4.0, "rx"),
    ("lwrist", "0 -1 0", 1.0, ""),
    ("rclavicle", "-1 0 0", 3.0, ""),
    ("rhumerus", "0 -1 0", 5.0, "rx ry rz"),
    ("rradius", "0 -1 0", 4.0, "rx"),
    ("rwrist", "0 -1 0", 1.0, ""),
]


def _asf() -> str:
    blocks = []
    for i, (name, d, length, dof) in enumerate(BONES):
        v = np.array(d.split(), float)
        v /= np.linalg.norm(v)
        blocks.append(
            f"  begin\n     id {i + 1}\n     name {name}\n     direction {' '.join(map(str, v))}\n"
            f"     length {length}\n     axis 0 0 0  XYZ\n" + (f"    dof {dof}\n" if dof else "") + "  end"
        )
    return ASF.format(bones="\n".join(blocks))


def _amc(frames: list[dict[str, str]]) -> str:
    out = [":FULLY-SPECIFIED", ":DEGREES"]
    for k, f in enumerate(frames, 1):
        out.append(str(k))
        out.append("root " + f.get("root", "0 16 0 0 0 0"))
        for name, _, _, dof in BONES:
            if dof:
                out.append(f"{name} " + f.get(name, " ".join("0" for _ in dof.split())))
    return "\r\n".join(out) + "\r\n"


def test_acclaim_rest_pose_units_axes_and_mapping() -> None:
    sk = acclaim.parse_asf(_asf())
    posed = acclaim.forward_kinematics(sk, acclaim.parse_amc(_amc([{}, {}]), sk))
    j = posed.joints[0]
    unit = 0.0254 / 0.45
    # +X of the file is the person's left: CAVE x = -x, so the left hip lies at negative CAVE x.
    assert j[J["l_hip"], 0] < 0 < j[J["r_hip"], 0]
    assert np.isclose(np.linalg.norm(j[J["l_hip"]] - j[J["l_knee"]]), 7 * unit)
    assert np.isclose(j[J["l_knee"], 2] - j[J["l_ankle"], 2], 7 * unit)  # +Y up -> CAVE z
    assert np.isclose(posed.pelvis[0, 2], 16 * unit)
    assert j[J["nose"], 1] > j[J["l_ear"], 1] and j[J["l_ear"], 0] < j[J["r_ear"], 0]  # face forward (+Y)
    assert np.isfinite(posed.joints).all() and posed.foot_points.shape == (2, 6, 3)


def test_acclaim_knee_flexion_moves_the_ankle_back_and_root_yaw_turns_ccw() -> None:
    sk = acclaim.parse_asf(_asf())
    posed = acclaim.forward_kinematics(
        sk, acclaim.parse_amc(_amc([{}, {"ltibia": "90"}, {"root": "0 16 0 0 90 0"}]), sk)
    )
    j = posed.joints
    shank = j[1, J["l_ankle"]] - j[1, J["l_knee"]]
    assert shank[1] < -0.3 and abs(shank[2]) < 1e-6  # the shank points backwards (-Y), horizontal
    fwd0 = j[0, J["nose"]] - 0.5 * (j[0, J["l_ear"]] + j[0, J["r_ear"]])
    fwd2 = j[2, J["nose"]] - 0.5 * (j[2, J["l_ear"]] + j[2, J["r_ear"]])
    turn = np.degrees(np.arctan2(fwd2[1], fwd2[0]) - np.arctan2(fwd0[1], fwd0[0]))
    assert np.isclose(turn, 90.0, atol=1e-6)  # +ry about +Y up: counter-clockwise seen from above


def test_acclaim_bad_files_are_one_clear_error() -> None:
    with pytest.raises(InputError, match="not an ASF"):
        acclaim.parse_asf("hello")
    sk = acclaim.parse_asf(_asf())
    with pytest.raises(InputError, match="not an AMC"):
        acclaim.parse_amc("1\nroot 0 0 0 0 0 0\n", sk)
    with pytest.raises(InputError, match="values per frame"):
        acclaim.parse_amc(_amc([{}, {"ltibia": "1 2"}]), sk)


def test_belt_velocity_is_the_stance_feet_velocity() -> None:
    t = np.arange(120) / 30
    ankles = np.zeros((120, 2, 3))
    phase = (t * 1.0) % 1.0
    for k in (0, 1):
        ph = (phase + 0.5 * k) % 1.0
        swing = ph > 0.6
        ankles[:, k, 2] = 0.08 + np.where(swing, 0.15 * np.sin(np.pi * (ph - 0.6) / 0.4), 0.0)
        ankles[:, k, 1] = np.where(swing, -0.6 + 1.2 * (ph - 0.6) / 0.4, 0.6 - 1.2 * ph / 0.6 * 0.6 / 0.6)
    v = belt_velocity(ankles, 30.0)
    assert abs(v[0]) < 1e-9 and v[1] < -0.5


def test_catalogue_has_the_new_sources_with_their_licences() -> None:
    clips = {c.id: c for c in load_catalogue()}
    assert clips["gaitalytics-treadmill-walk"].treadmill
    assert clips["cmu-01-01-jumps"].skeleton == "demo/test.asf"
    assert "CMU" in clips["cmu-01-01-jumps"].licence


def _landmark_file(frames: list[dict[str, list[float]]], valid: list[bool] | None = None) -> str:
    rows = [{"frame_index": i, "landmark_positions": f, "is_valid": True if valid is None else valid[i]}
            for i, f in enumerate(frames)]  # fmt: skip
    return json.dumps({"fps": 100.0, "n_frames": len(rows), "angle_frames": rows})


def test_gaitkit_landmarks_axes_units_and_gaps() -> None:
    base = {  # mm, +Y up in the file, walking along +X, the right side at +Z
        "left_hip": [0, 900, -80], "right_hip": [0, 900, 80], "left_knee": [0, 500, -80],
        "right_knee": [0, 500, 80], "left_ankle": [0, 80, -80], "right_ankle": [0, 80, 80],
        "left_heel": [-50, 30, -80], "right_heel": [-50, 30, 80], "left_toe": [150, 20, -80],
        "right_toe": [150, 20, 80], "left_shoulder": [0, 1400, -180], "right_shoulder": [0, 0, 0],
    }  # fmt: skip
    text = _landmark_file([base, base, base], valid=[True, False, True])
    joints, feet, pelvis, fps = read_landmarks(text, "y")
    assert fps == 100.0 and joints.shape == (3, 17, 3) and feet.shape == (3, 6, 3)
    assert np.allclose(joints[0, J["l_hip"]], [0.0, 0.08, 0.9])  # y up -> CAVE z; file z -> CAVE -y
    assert np.allclose(joints[0, J["r_ankle"]], [0.0, -0.08, 0.08]) and np.allclose(pelvis[0], [0, 0, 0.9])
    assert np.isnan(joints[0, J["r_shoulder"]]).all()  # (0, 0, 0) is "absent"
    assert np.isnan(joints[1]).all()  # an invalid frame
    assert np.isnan(joints[:, [J["nose"], J["l_wrist"], J["r_elbow"]]]).all()  # not in the files
    with pytest.raises(InputError, match="up_axis"):
        read_landmarks(text, "x")
    with pytest.raises(InputError, match="not a gaitkit landmark file"):
        read_landmarks("{}", "y")


def test_a_labs_asf_amc_pair_converts_with_its_skeleton(tmp_path: Path) -> None:
    """`pipeline.mocap.convert` (cavewalk data convert) on an ASF/AMC pair: the person in the ASF's
    units, on the floor, at 30 fps from 120 Hz, labelled still by a whole-clip rule; an AMC without its
    ASF, or an ASF that is not one, is one InputError."""
    (tmp_path / "p.asf").write_text(_asf())
    (tmp_path / "stand.amc").write_text(_amc([{} for _ in range(240)]))
    req = ConvertRequest(tmp_path / "stand.amc", LabelRule("still", "still", "stand"), tmp_path / "p.asf")
    seq = convert_file(req)
    assert seq.fps == 30.0 and 59 <= len(seq.joints_m) <= 61 and seq.source == "stand"
    assert set(seq.labels or ()) == {"still"} and set(seq.tags or ()) == {"stand"}
    assert np.nanmin(seq.joints_m[..., 2]) > -0.01
    with pytest.raises(InputError, match="needs its ASF skeleton"):
        convert_file(ConvertRequest(tmp_path / "stand.amc"))
    (tmp_path / "bad.asf").write_text("hello")
    with pytest.raises(InputError, match="not an ASF file"):
        convert_file(replace(req, skeleton=tmp_path / "bad.asf"))
