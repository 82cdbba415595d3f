"""Isaac Lab's AMP humanoid motions (pipeline.mocap.amp): the reader on NPZs written here, and the
real clips of the pinned isaaclab 3.0.0 wheel (evaluation only; downloaded once into the cache)."""

from __future__ import annotations

import io
from typing import Any

import numpy as np
import pytest

from pipeline.errors import InputError
from pipeline.mocap.amp import level_floor, read_amp_motion
from pipeline.mocap.fetch import (
    PACKAGES,
    convert_amp,
    load_catalogue,
)
from pipeline.skeleton import J
from tests.pipeline.mocap.pinned import pinned_clips

# The AMP humanoid's rest pose: body origins (m, +X forward, +Y left, +Z up), parents before children.
REST = {
    "pelvis": (0.0, 0.0, 0.9), "torso": (0.0, 0.0, 1.136), "head": (0.0, 0.0, 1.36),
    "right_upper_arm": (-0.024, -0.183, 1.38), "right_lower_arm": (-0.024, -0.183, 1.105),
    "right_hand": (-0.024, -0.183, 0.846), "left_upper_arm": (-0.024, 0.183, 1.38),
    "left_lower_arm": (-0.024, 0.183, 1.105), "left_hand": (-0.024, 0.183, 0.846),
    "right_thigh": (0.0, -0.085, 0.9), "right_shin": (0.0, -0.085, 0.478), "right_foot": (0.0, -0.085, 0.068),
    "left_thigh": (0.0, 0.085, 0.9), "left_shin": (0.0, 0.085, 0.478), "left_foot": (0.0, 0.085, 0.068),
}  # fmt: skip


def amp_npz(frames: int = 3, fps: int = 60, drop: str = "", rotations: np.ndarray | None = None) -> bytes:
    """An AMP motion NPZ of the rest pose held for ``frames`` frames (identity rotations)."""
    names = [n for n in REST if n != drop]
    pos = np.tile(np.array([REST[n] for n in names], dtype=np.float32), (frames, 1, 1))
    rot = np.zeros((frames, len(names), 4), dtype=np.float32)
    rot[..., 0] = 1.0
    buf = io.BytesIO()
    np.savez(buf, fps=np.int64(fps), body_names=np.array(names), body_positions=pos,
             body_rotations=rot if rotations is None else rotations)  # fmt: skip
    return buf.getvalue()


def test_amp_rest_pose_mapping_face_and_soles() -> None:
    joints, feet, pelvis, fps = read_amp_motion(amp_npz())
    assert fps == 60.0 and joints.shape == (3, 17, 3) and feet.shape == (3, 8, 3)
    assert np.isfinite(joints).all(), "every COCO joint is placed"
    assert np.allclose(joints[0, J["l_hip"]], REST["left_thigh"]) and np.allclose(pelvis[0], REST["pelvis"])
    assert np.allclose(joints[0, J["r_wrist"]], REST["right_hand"])
    assert np.allclose(joints[0, J["l_ankle"]], REST["left_foot"], atol=1e-6)
    nose, l_ear, r_ear = joints[0, J["nose"]], joints[0, J["l_ear"]], joints[0, J["r_ear"]]
    assert nose[0] > 0.09 and abs(nose[1]) < 1e-9, "the nose is in front (+X) of the head"
    assert l_ear[1] > 0.07 and r_ear[1] < -0.07, "left is +Y"
    assert 1.5 < nose[2] < 1.56, "the face on the head sphere, 0.175 m above the neck"
    assert np.allclose(feet[0, :, 2], REST["left_foot"][2] - 0.05), "soles 5 cm below the ankles"
    assert np.allclose(sorted(set(np.round(feet[0, :4, 0], 4))), [-0.0435, 0.1335])


def test_amp_rotated_head_turns_the_face() -> None:
    rot = np.zeros((2, len(REST), 4))
    rot[..., 0] = 1.0
    rot[:, list(REST).index("head")] = [np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)]  # 90 deg left
    joints, _, _, _ = read_amp_motion(amp_npz(frames=2, rotations=rot))
    assert joints[0, J["nose"], 1] > 0.09 and abs(joints[0, J["nose"], 0]) < 1e-6


def test_level_floor_removes_a_linear_drift_only_in_height() -> None:
    joints, feet, pelvis, fps = read_amp_motion(amp_npz(frames=120))
    t = np.arange(120) / fps
    rise = 0.02 * t  # 2 cm/s
    j2, f2, p2 = joints + rise[:, None, None] * [0, 0, 1], feet + rise[:, None, None] * [0, 0, 1], pelvis
    lj, lf, lp = level_floor(j2, f2, p2 + rise[:, None] * [0, 0, 1], fps)
    assert np.allclose(lf[..., 2] - lf[0, :, 2], 0.0, atol=1e-9) and np.allclose(lj[..., :2], joints[..., :2])
    assert np.allclose(lp[:, 2], pelvis[0, 2])


@pytest.mark.parametrize(
    ("data", "match"),
    [
        (b"not an npz", "not an AMP motion NPZ"),
        (amp_npz(drop="head"), r"lacks the bodies \['head'\]"),
        (amp_npz(frames=1), "at least 2 finite frames"),
        (amp_npz(rotations=np.ones((3, 2, 4), dtype=np.float32)), "expected body_positions"),
    ],
)
def test_amp_bad_files_are_one_clear_error(data: bytes, match: str) -> None:
    with pytest.raises(InputError, match=match):
        read_amp_motion(data)


def test_amp_clips_are_catalogued_for_evaluation_only() -> None:
    clips = [c for c in load_catalogue() if c.package == "isaaclab"]
    assert {c.id for c in clips} == {"isaaclab-amp-dance", "isaaclab-amp-walk", "isaaclab-amp-run"}
    assert all(c.use == "eval" and c.format == "amp-npz" for c in clips), (
        "origin undocumented: never trained on"
    )
    assert PACKAGES["isaaclab"].is_wheel and PACKAGES["isaaclab"].member("a/b.npz") == "a/b.npz"


@pytest.mark.slow
def test_real_amp_clips_convert(base_settings: Any) -> None:
    """The three motions of the pinned wheel (downloaded like `cavewalk data mocap` does)."""
    specs, files = pinned_clips("isaaclab", base_settings.paths.cache_dir)
    seqs = {i: convert_amp(files[c.path], c) for i, c in specs.items()}
    for seq in seqs.values():
        assert seq.fps == 30.0 and np.isfinite(seq.joints_m).all() and seq.contacts is not None
        assert 1.45 < np.median(seq.joints_m[:, J["nose"], 2]) < 1.6  # the model is ~1.6 m tall
        ankles = seq.joints_m[:, [J["l_ankle"], J["r_ankle"]], 2]
        assert 0.03 < np.percentile(ankles, 5) < 0.12, "ankles just above the floor in stance"
    walk, run, dance = seqs["isaaclab-amp-walk"], seqs["isaaclab-amp-run"], seqs["isaaclab-amp-dance"]
    assert len(walk) == 77 and walk.labels is not None and set(walk.labels) == {"forward"}
    assert walk.contacts is not None and walk.contacts.any(axis=1).mean() > 0.8, "level floor: stances seen"
    lifts = [int(np.sum(np.diff(walk.contacts[:, k].astype(int)) == -1)) for k in (0, 1)]
    assert min(lifts) >= 2, f"alternating steps, got lifts {lifts}"
    assert len(run) == 41 and run.labels is not None and set(run.labels) == {"forward"}
    assert len(dance) == 451 and dance.labels is not None and set(dance.labels) == {"still", "ignore"}
    assert dance.labels.count("still") > 250  # both feet down most of the time; a raised foot -> ignore
