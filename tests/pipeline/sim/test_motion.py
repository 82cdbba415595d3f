"""Animated users: labels, yaw, speed and the kinematics of each action."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.errors import InputError
from pipeline.sim.motion import (
    STEP_LENGTH_M,
    MotionScript,
    MotionStyle,
    Segment,
    UserMotion,
    body_from_height,
    load_script,
    random_script,
    sample_body,
    sample_style,
    simulate_user,
)
from pipeline.skeleton import ACTIONS, J, load_npz, save_npz

FPS = 30.0


def _dominant_hz(signal: np.ndarray, fps: float) -> float:
    x = signal - signal.mean()
    n = 8 * len(x)  # zero-padding for a finer frequency grid
    spec = np.abs(np.fft.rfft(x * np.hanning(len(x)), n))
    freqs = np.fft.rfftfreq(n, 1.0 / fps)
    return float(freqs[np.argmax(spec[1:]) + 1])


@pytest.mark.parametrize("cadence", [1.2, 1.8, 2.4])
@pytest.mark.parametrize("seed", [0, 7])
def test_forward_ankles_alternate_at_the_scripted_cadence(cadence: float, seed: int) -> None:
    script = MotionScript((Segment("still", 1.0), Segment("forward", 16.0, cadence_steps_per_s=cadence)))
    body = sample_body(np.random.default_rng(seed))
    m = simulate_user(script, body, fps=FPS, seed=seed)
    seg = slice(int(2 * FPS), len(m))  # after the blend-in
    lz = m.joints_m[seg, J["l_ankle"], 2]
    rz = m.joints_m[seg, J["r_ankle"], 2]
    # each ankle rises once per two steps: the left-right difference oscillates at cadence / 2
    f = _dominant_hz(lz - rz, FPS)
    assert abs(f - cadence / 2) < 0.08, f"ankle alternation at {f:.3f} Hz, script says {cadence / 2:.3f} Hz"
    rise_l = lz - lz.min()
    rise_r = rz - rz.min()
    assert 0.04 < rise_l.max() < 0.32 and 0.04 < rise_r.max() < 0.32, "ankle rise out of the 5-25 cm band"
    both_up = (rise_l > 0.03) & (rise_r > 0.03)
    assert both_up.mean() < 0.02, "both feet are in the air at once while marching"
    # feet stay roughly in place
    drift = np.linalg.norm(m.root_xy_m[-1] - m.root_xy_m[0])
    assert drift < 0.6, f"marching in place drifted {drift:.2f} m"


@pytest.mark.parametrize("yaw", [0.0, 90.0, -135.0, 180.0, 33.0])
@pytest.mark.parametrize("direction", ["left", "right"])
def test_side_steps_go_towards_the_side_relative_to_yaw(yaw: float, direction: str) -> None:
    script = MotionScript(
        (Segment("still", 1.0), Segment(direction, 5.0)), start_xy_m=(0.3, -0.2), start_yaw_deg=yaw
    )
    m = simulate_user(script, body_from_height(1.75), fps=FPS, seed=3)
    right = np.array([np.cos(np.radians(yaw)), np.sin(np.radians(yaw))])  # the user's right, CAVE frame
    sign = -1.0 if direction == "left" else 1.0
    lead = J["l_ankle"] if direction == "left" else J["r_ankle"]
    trail = J["r_ankle"] if direction == "left" else J["l_ankle"]
    ref = m.joints_m[: int(FPS), :, :2].mean(axis=0)  # the still second
    side = m.joints_m[int(1.5 * FPS) :, :, :2]
    lead_out = ((side[:, lead] - ref[lead]) @ right) * sign
    trail_out = ((side[:, trail] - ref[trail]) @ right) * sign
    hip_idx = [J["l_hip"], J["r_hip"]]
    hips = (side[:, hip_idx].mean(axis=1) - ref[hip_idx].mean(axis=0)) @ right
    assert lead_out.max() > 0.08, f"the {direction} foot never stepped out ({lead_out.max():.3f} m)"
    assert lead_out.min() > -0.05, "the leading foot crossed to the other side"
    assert abs(trail_out).max() < 0.1, "the trailing foot should stay roughly in place"
    assert np.percentile(hips * sign, 90) > 0.03, "the pelvis does not follow the side step"
    assert set(m.labels[int(1.0 * FPS) :]) == {direction}


def test_labels_yaw_and_speed_follow_the_script() -> None:
    script = MotionScript(
        (
            Segment("still", 2.0),
            Segment("forward", 3.0, cadence_steps_per_s=2.0),
            Segment("turn", 1.5, turn_deg=-90),
            Segment("left", 2.0, cadence_steps_per_s=1.5),
            Segment("forward", 2.0, turn_deg=30),
        ),
        start_yaw_deg=170.0,
    )
    style = MotionStyle(cadence_drift=0.0)
    m = simulate_user(script, body_from_height(1.6), fps=FPS, seed=1, style=style)
    assert len(m) == round(script.duration_s * FPS)
    expected = ["still"] * 60 + ["forward"] * 90 + ["still"] * 45 + ["left"] * 60 + ["forward"] * 60
    assert list(m.labels) == expected, "labels must switch at the true onset of each segment"
    assert set(m.labels) <= set(ACTIONS)
    # yaw: 170 during the first two segments, turning by -90 (wrapping through 180 is fine), then +30
    assert np.allclose(m.yaw_deg[:150], 170.0)
    assert m.yaw_deg[194] == pytest.approx(80.0, abs=0.5)
    assert np.allclose(m.yaw_deg[195:255], 80.0)
    assert m.yaw_deg[-1] == pytest.approx(110.0, abs=0.5)
    assert np.all((m.yaw_deg > -180.0) & (m.yaw_deg <= 180.0))
    still = np.array(m.labels) == "still"
    assert np.all(m.speed_mps[still] == 0.0)
    # intended speed: the bout's realised cadence x the step length, constant over the bout
    assert np.ptp(m.speed_mps[60:150]) == 0.0 and np.ptp(m.speed_mps[195:255]) == 0.0
    assert m.speed_mps[60] == pytest.approx(2.0 * STEP_LENGTH_M["forward"], rel=0.05)
    assert m.speed_mps[195] == pytest.approx(1.5 * STEP_LENGTH_M["left"], rel=0.05)


def test_the_body_is_rigid_and_stands_on_the_floor() -> None:
    rng = np.random.default_rng(5)
    body = sample_body(rng)
    m = simulate_user(random_script(rng, 30.0), body, fps=FPS, seed=5)
    j = m.joints_m
    for a, b, length in (
        ("l_shoulder", "l_elbow", body.upper_arm_m),
        ("r_elbow", "r_wrist", body.forearm_m),
        ("l_hip", "l_knee", body.thigh_m),
        ("r_knee", "r_ankle", body.shin_m),
    ):
        d = np.linalg.norm(j[:, J[a]] - j[:, J[b]], axis=-1)
        assert np.allclose(d, length, atol=2e-3), f"{a}-{b} length varies {d.min():.3f}..{d.max():.3f}"
    ankles_z = j[:, [J["l_ankle"], J["r_ankle"]], 2]
    assert ankles_z.min() > body.ankle_height_m - 0.01, "a foot went through the floor"
    assert np.all(j[:, J["nose"], 2] > j[:, J["l_shoulder"], 2]), "head below the shoulders"
    assert np.all(np.isfinite(j))


def test_same_seed_same_motion_other_seed_other_motion() -> None:
    script = random_script(np.random.default_rng(11), 8.0)
    body = body_from_height(1.8)
    a = simulate_user(script, body, seed=4)
    b = simulate_user(script, body, seed=4)
    c = simulate_user(script, body, seed=5)
    assert np.array_equal(a.joints_m, b.joints_m) and a.labels == b.labels
    assert np.array_equal(a.speed_mps, b.speed_mps)
    assert not np.allclose(a.joints_m, c.joints_m)
    assert random_script(np.random.default_rng(2), 20.0) == random_script(np.random.default_rng(2), 20.0)
    assert sample_style(np.random.default_rng(1)) != sample_style(np.random.default_rng(2))


def test_random_script_covers_the_duration_with_varied_actions() -> None:
    rng = np.random.default_rng(0)
    script = random_script(rng, 120.0)
    assert script.duration_s == pytest.approx(120.0)
    actions = [s.action for s in script.segments]
    assert set(actions) == {"still", "forward", "left", "right", "turn"}
    assert all(a != b for a, b in itertools.pairwise(actions)), "consecutive repeats"
    only = random_script(rng, 10.0, action_weights={"forward": 1.0})
    assert {s.action for s in only.segments} == {"forward"}


def test_sample_body_respects_the_height_range_and_varies_proportions() -> None:
    rng = np.random.default_rng(0)
    bodies = [sample_body(rng) for _ in range(300)]
    heights = np.array([b.height_m for b in bodies])
    assert heights.min() >= 1.40 and heights.max() <= 2.05
    assert heights.min() < 1.45 and heights.max() > 2.0, "the whole 1.40-2.05 m range is drawn"
    legs = np.array([b.hip_height_m / b.height_m for b in bodies])
    arms = np.array([(b.upper_arm_m + b.forearm_m) / b.height_m for b in bodies])
    shoulders = np.array([b.shoulder_width_m / b.height_m for b in bodies])
    for name, ratio, spread in (("leg", legs, 0.04), ("arm", arms, 0.04), ("shoulder", shoulders, 0.03)):
        assert np.ptp(ratio) > spread, f"{name} proportions hardly vary: {ratio.min():.3f}..{ratio.max():.3f}"
    with pytest.raises(InputError, match="height_range"):
        sample_body(rng, (1.9, 1.5))


def test_to_sequence_round_trips_through_the_npz_file(tmp_path: Path) -> None:
    m = simulate_user(MotionScript((Segment("forward", 2.0),)), body_from_height(1.7), fps=25.0)
    assert isinstance(m, UserMotion)
    save_npz(tmp_path / "s.npz", m.to_sequence())
    seq = load_npz(tmp_path / "s.npz")
    assert seq.fps == 25.0 and seq.labels == m.labels
    assert np.allclose(seq.joints_m, m.joints_m, atol=1e-5)


GOOD = {
    "segments": [
        {"action": "still", "duration_s": 1},
        {"action": "forward", "duration_s": 2, "cadence_steps_per_s": 1.8},
    ]
}


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("{not json", "not valid JSON"),
        ("[]", "expected an object"),
        ('{"segments": []}', "non-empty list"),
        ('{"segs": []}', "unknown key"),
        ('{"segments": [{"action": "jump", "duration_s": 1}]}', "segment 1: action must be one of"),
        ('{"segments": [{"action": "still"}]}', "segment 1: missing 'duration_s'"),
        ('{"segments": [{"action": "still", "duration_s": -2}]}', "duration_s must be > 0"),
        ('{"segments": [{"action": "still", "duration_s": "3"}]}', "duration_s must be a number"),
        (
            '{"segments": [{"action": "still", "duration_s": 1}, {"action": "forward", "duration_s": 1, '
            '"cadence_steps_per_s": 9}]}',
            "segment 2: cadence_steps_per_s must be in",
        ),
        ('{"segments": [{"action": "left", "duration_s": 1, "speed": 2}]}', "unknown key"),
        ('{"segments": [{"action": "forward", "duration_s": 1, "gestures": ["wave"]}]}', "only for still"),
        ('{"segments": [{"action": "still", "duration_s": 1, "gestures": ["dance"]}]}', "unknown gesture"),
        ('{"segments": [{"action": "still", "duration_s": 1}], "start_xy_m": [1]}', "start_xy_m"),
        ('{"segments": [{"action": "left", "duration_s": 1, "behaviour": "march"}]}', "is not one of 'left'"),
        ('{"segments": [{"action": "forward", "duration_s": 1, "behaviour": "walk"}]}', "needs travel_mps"),
        ('{"segments": [{"action": "forward", "duration_s": 1, "pause_s": [0.1, 0.5]}]}', "pause_s must sat"),
        ('{"segments": [{"action": "forward", "duration_s": 1, "pause_s": 0.5}]}', r"pause_s must be \[min"),
        ('{"segments": [{"action": "forward", "duration_s": 1, "asymmetry": 3}]}', "asymmetry must be in"),
        ('{"segments": [{"action": "forward", "duration_s": 1, "travel_mps": 5}]}', "travel_mps must be in"),
    ],
)
def test_bad_scripts_are_rejected_with_a_clear_message(tmp_path: Path, text: str, match: str) -> None:
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(InputError, match=match):
        load_script(path)


def test_script_files_load_from_json_and_toml(tmp_path: Path) -> None:
    (tmp_path / "s.json").write_text(json.dumps(GOOD))
    (tmp_path / "s.toml").write_text(
        'start_yaw_deg = 45\n[[segments]]\naction = "still"\nduration_s = 1\n'
        '[[segments]]\naction = "forward"\nduration_s = 2\ncadence_steps_per_s = 1.8\n'
    )
    a = load_script(tmp_path / "s.json")
    b = load_script(tmp_path / "s.toml")
    assert a.segments == b.segments
    assert b.start_yaw_deg == 45.0 and a.duration_s == 3.0
    with pytest.raises(InputError, match="not found"):
        load_script(tmp_path / "missing.json")
    (tmp_path / "bad.toml").write_text("[[segments]\n")
    with pytest.raises(InputError, match="not valid TOML"):
        load_script(tmp_path / "bad.toml")


def test_shipped_example_scripts_load() -> None:
    folder = Path(__file__).resolve().parents[3] / "pipeline" / "sim" / "scripts"
    files = sorted(folder.glob("*.json"))
    assert len(files) >= 2
    for f in files:
        script = load_script(f)
        assert script.duration_s > 0


@settings(max_examples=25, deadline=None)
@given(yaw=st.floats(-180.0, 180.0), turn=st.floats(-180.0, 180.0), seed=st.integers(0, 2**16))
def test_turning_the_start_yaw_turns_the_whole_motion_about_the_start_point(
    yaw: float, turn: float, seed: int
) -> None:
    segs = (Segment("still", 0.5), Segment("left", 0.7), Segment("forward", 0.5, turn_deg=20.0))
    start = (0.4, -0.3)
    a = simulate_user(
        MotionScript(segs, start_xy_m=start, start_yaw_deg=yaw), body_from_height(1.7), seed=seed
    )
    b = simulate_user(
        MotionScript(segs, start_xy_m=start, start_yaw_deg=yaw + turn), body_from_height(1.7), seed=seed
    )
    c, s = np.cos(np.radians(turn)), np.sin(np.radians(turn))
    rot = np.array([[c, -s], [s, c]])
    rotated = (a.joints_m[..., :2] - start) @ rot.T + start
    assert np.allclose(b.joints_m[..., :2], rotated, atol=1e-9)
    assert np.allclose(b.joints_m[..., 2], a.joints_m[..., 2])
    assert np.allclose(((b.yaw_deg - a.yaw_deg - turn + 180.0) % 360.0) - 180.0, 0.0, atol=1e-9)
    assert a.labels == b.labels


def test_stepping_starts_at_the_labelled_onset() -> None:
    script = MotionScript((Segment("still", 2.0), Segment("forward", 2.0, blend_s=0.2)))
    m = simulate_user(script, body_from_height(1.75), fps=FPS, seed=2)
    onset = m.labels.index("forward")
    assert onset == 60
    ankles = m.joints_m[:, [J["l_ankle"], J["r_ankle"]], 2]
    rest = ankles[:onset]
    assert np.ptp(rest) < 1e-3, "the feet must stay on the floor before the onset"
    assert ankles[onset : onset + 10].max() > rest.max() + 0.01, (
        "a foot must leave the floor soon after the onset"
    )


def _turn_swings(m: UserMotion) -> list[tuple[int, int, int]]:
    """(foot, lift frame, land frame) of each foot's swings from the ground-truth contacts."""
    out = []
    for k in (0, 1):
        c = m.contacts[:, k]
        for i in range(1, len(c)):
            if c[i - 1] and not c[i]:
                j = i
                while j < len(c) and not c[j]:
                    j += 1
                out.append((k, i, j))
    return sorted(out, key=lambda s: s[1])


def test_turns_on_the_spot_come_in_both_styles_irregular_and_rhythmic_pivot_steps() -> None:
    """A turn on the spot is still; some people re-place their feet now and then, others step left
    and right in turn like a march while the body turns: both must be in the still library."""
    rhythmic = irregular = 0
    for seed in range(12):
        turn = Segment("turn", 3.0, turn_deg=150.0)
        script = MotionScript((Segment("still", 1.0), turn, Segment("still", 1.0)))
        m = simulate_user(script, sample_body(np.random.default_rng(seed)), fps=FPS, seed=seed)
        assert set(m.labels) == {"still"}
        swings = [s for s in _turn_swings(m) if FPS <= s[1] < 4 * FPS]
        feet = [s[0] for s in swings]
        alternating = len(feet) >= 4 and all(a != b for a, b in itertools.pairwise(feet))
        starts = np.array([s[1] for s in swings]) / FPS
        regular = len(starts) >= 4 and np.std(np.diff(starts)) < 0.15 * np.mean(np.diff(starts))
        if alternating and regular:
            rhythmic += 1
            lifts = [np.ptp(m.joints_m[a:b, J["l_ankle"] + k, 2]) for k, a, b in swings]
            assert 0.01 < np.median(lifts) < 0.1, f"pivot steps lift 2-8 cm, got {np.median(lifts):.3f} m"
        else:
            irregular += 1
        yaw_turned = (m.yaw_deg[int(4 * FPS)] - m.yaw_deg[int(FPS)] + 180) % 360 - 180
        assert abs(yaw_turned - 150.0) < 5.0, f"the body turned {yaw_turned:.0f} degrees, not 150"
    assert rhythmic >= 3 and irregular >= 3, f"{rhythmic} rhythmic and {irregular} irregular turns of 12"
