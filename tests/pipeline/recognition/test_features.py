"""Pre-processing: the model's input does not depend on where the user stands or faces."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.recognition.features import (
    CHANNELS_PER_JOINT,
    EVIDENCE_CHANNELS,
    NUM_CHANNELS,
    FeatureWindow,
    RingWindow,
    facing_vector,
    facing_vectors,
    fill_unknown,
    frame_parts,
    normalize_window,
    pelvis,
    to_model_input,
    to_model_input_v2,
    torso_length,
    window_features,
)
from pipeline.skeleton import J

from .conftest import rot_z, standing_pose


def _marching(frames: int = 32, seed: int = 0) -> np.ndarray:
    """A person facing +Y lifting knees alternately, with measurement noise and a few gaps."""
    rng = np.random.default_rng(seed)
    base = standing_pose()
    t = np.arange(frames) / 30.0
    seq = np.repeat(base[None], frames, axis=0)
    lift = 0.15 * np.sin(2 * np.pi * 0.9 * t)
    for side, sign in (("l", 1.0), ("r", -1.0)):
        up = np.clip(sign * lift, 0.0, None)
        seq[:, J[f"{side}_knee"], 2] += up
        seq[:, J[f"{side}_knee"], 1] += up
        seq[:, J[f"{side}_ankle"], 2] += up
    seq += rng.normal(0.0, 0.01, seq.shape)
    seq[4:7, J["l_wrist"]] = np.nan
    seq[10, J["r_knee"]] = np.nan
    return seq


@settings(max_examples=30, deadline=None)
@given(
    yaw=st.floats(-180.0, 180.0),
    dx=st.floats(-1.5, 1.5),
    dy=st.floats(-1.5, 1.5),
    dz=st.floats(-0.2, 0.2),
)
def test_translating_and_rotating_the_input_changes_nothing(
    yaw: float, dx: float, dy: float, dz: float
) -> None:
    seq = _marching()
    moved = seq @ rot_z(yaw).T + np.array([dx, dy, dz])
    a, b = window_features(seq, 30.0), window_features(moved, 30.0)
    np.testing.assert_allclose(a, b, atol=1e-4, err_msg=f"features changed for yaw {yaw}, shift {dx, dy, dz}")


@pytest.mark.parametrize("scale", [0.85, 1.1])
def test_scaling_the_body_changes_nothing(scale: float) -> None:
    seq = _marching()
    np.testing.assert_allclose(window_features(seq, 30.0), window_features(seq * scale, 30.0), atol=1e-4)


def test_normalised_person_faces_plus_y_and_is_pelvis_centred() -> None:
    seq = _marching() @ rot_z(123.0).T + np.array([0.7, -0.4, 0.0])
    norm = normalize_window(seq)
    hips = 0.5 * (norm[:, J["l_hip"]] + norm[:, J["r_hip"]])
    assert np.abs(np.nanmean(hips, axis=0)).max() < 1e-9, "the window's mean pelvis is the origin"
    # facing +Y: the left shoulder is at -X, the nose in front (+Y)
    assert np.nanmean(norm[:, J["l_shoulder"], 0]) < -0.3
    assert np.nanmean(norm[:, J["r_shoulder"], 0]) > 0.3
    assert np.nanmean(norm[:, J["nose"], 1]) > 0.1
    assert torso_length(seq) == pytest.approx(0.5, abs=0.02)


def test_unknown_joints_take_the_last_known_value_and_are_flagged() -> None:
    seq = np.repeat(standing_pose()[None], 6, axis=0)
    seq[:, J["l_wrist"], 0] = np.arange(6) * 0.01
    seq[2:4, J["l_wrist"]] = np.nan  # gap: frames 2-3 hold frame 1
    seq[:2, J["r_wrist"]] = np.nan  # unknown at the start: the first known value
    seq[:, J["nose"]] = np.nan  # never known: zero
    filled, known = fill_unknown(seq)
    assert np.isfinite(filled).all()
    np.testing.assert_allclose(filled[2:4, J["l_wrist"]], seq[[1, 1], J["l_wrist"]])
    np.testing.assert_allclose(filled[:2, J["r_wrist"]], seq[[2, 2], J["r_wrist"]])
    np.testing.assert_array_equal(filled[:, J["nose"]], 0.0)
    assert not known[2:4, J["l_wrist"]].any() and known[[0, 1, 4, 5], J["l_wrist"]].all()
    feats = window_features(seq, 30.0)
    np.testing.assert_array_equal(feats[..., 6], known.astype(np.float32), err_msg="channel 7 is the mask")
    assert np.isfinite(feats).all()
    other = seq.copy()
    other[:, J["nose"]] = standing_pose()[J["nose"]]
    other[4:, J["l_wrist"], 1] = np.nan  # one coordinate unknown: the joint is unknown
    batch, batch_known = fill_unknown(np.stack([seq, other]))  # windows filled one by one, batched
    for i, window in enumerate((seq, other)):
        one, one_known = fill_unknown(window)
        np.testing.assert_array_equal(batch[i], one)
        np.testing.assert_array_equal(batch_known[i], one_known)
    np.testing.assert_allclose(batch[1, 2:, J["l_wrist"]], other[[1, 1, 1, 1], J["l_wrist"]])


def _filled_one_by_one(seq: np.ndarray) -> np.ndarray:
    """fill_unknown's rule, joint by joint and frame by frame: the last known value, else the
    first known one, else 0 (a joint is known when all three coordinates are finite)."""
    out = seq.copy()
    for j in range(seq.shape[1]):
        known = [t for t in range(len(seq)) if np.isfinite(seq[t, j]).all()]
        for t in range(len(seq)):
            if t in known:
                continue
            before = [k for k in known if k < t]
            out[t, j] = seq[before[-1], j] if before else seq[known[0], j] if known else 0.0
    return out


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(0.0, 0.6))
def test_filling_unknown_joints_copies_exactly_the_values_the_rule_names(seed: int, share: float) -> None:
    """fill_unknown copies only the unknown joints, from the frames the rule names, for a batch of
    windows at once: NaN, an infinite coordinate, one coordinate of three, never-known joints."""
    rng = np.random.default_rng(seed)
    batch = rng.normal(0.0, 1.0, (3, 12, 17, 3))
    gaps = rng.random(batch.shape) < share / 3.0
    batch[gaps] = rng.choice([np.nan, np.inf, -np.inf], size=int(gaps.sum()))
    batch[1, :, 4] = np.nan  # one joint never known in one window
    filled, known = fill_unknown(batch)
    for w in range(len(batch)):
        np.testing.assert_array_equal(filled[w], _filled_one_by_one(batch[w]))
        np.testing.assert_array_equal(known[w], np.isfinite(batch[w]).all(axis=-1))
    assert np.isfinite(filled).all()


def test_velocity_channels_are_per_second_and_zero_across_gaps() -> None:
    seq = np.repeat(standing_pose()[None], 8, axis=0)
    seq[:, J["l_wrist"], 2] += np.arange(8) * 0.01  # 0.3 m/s upwards at 30 fps
    seq[5, J["l_wrist"]] = np.nan
    feats = window_features(seq, 30.0)
    torso = torso_length(seq)
    vz = feats[:, J["l_wrist"], 5]
    np.testing.assert_allclose(vz[[1, 2, 3, 4, 7]], 0.3 / torso, rtol=1e-3)
    assert vz[0] == 0 and vz[5] == 0 and vz[6] == 0, "no velocity into, out of or at a gap"


def test_batches_give_the_same_features_as_single_windows() -> None:
    a, b = _marching(seed=1), _marching(seed=2) @ rot_z(40.0).T
    batch = window_features(np.stack([a, b]), 30.0)
    np.testing.assert_allclose(batch[0], window_features(a, 30.0), atol=1e-6)
    np.testing.assert_allclose(batch[1], window_features(b, 30.0), atol=1e-6)
    x = to_model_input(batch)
    assert x.shape == (2, NUM_CHANNELS, 32)
    np.testing.assert_array_equal(x[1, J["l_knee"] * CHANNELS_PER_JOINT + 2], batch[1, :, J["l_knee"], 2])


@pytest.mark.parametrize(
    ("shape", "match"),
    [((32, 16, 3), r"\(\.\.\., 17, 3\)"), ((17, 3), r"time axis"), ((32, 17, 2), r"\(\.\.\., 17, 3\)")],
)
def test_bad_shapes_are_rejected(shape: tuple[int, ...], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        window_features(np.zeros(shape), 30.0)


def test_bad_fps_is_rejected() -> None:
    with pytest.raises(ValueError, match="fps"):
        window_features(_marching(), 0.0)


def _awkward_stream(frames: int = 80, seed: int = 3) -> np.ndarray:
    """A marching stream with what the live input holds: turning, a lost hip, no shoulders for a
    while, whole frames without data, a hip pair drawn on one spot, an infinite coordinate."""
    seq = np.concatenate([_marching(32, seed), _marching(32, seed + 1), _marching(frames - 64, seed + 2)])
    seq = np.stack([f @ rot_z(3.0 * i).T for i, f in enumerate(seq)])
    seq[12:20, J["l_hip"]] = np.nan
    seq[25:40, [J["l_shoulder"], J["r_shoulder"]]] = np.nan
    seq[44:47] = np.nan
    seq[50, J["r_hip"]] = seq[50, J["l_hip"]]
    seq[52, J["l_shoulder"], 0] = np.inf
    return seq


@pytest.mark.filterwarnings("ignore:invalid value encountered in matmul:RuntimeWarning")  # the infinite one
def test_the_streaming_window_gives_exactly_the_features_of_the_window() -> None:
    seq = _awkward_stream()
    win = FeatureWindow(32, 30.0)
    for i, frame in enumerate(seq):
        win.push(frame)
        window = seq[max(0, i - 31) : i + 1]
        if len(window) < 32:  # before the window is full: the first frame repeated in front
            window = np.concatenate([np.repeat(window[:1], 32 - len(window), axis=0), window])
        got = win.features()
        assert got.shape == (32, 17, CHANNELS_PER_JOINT)
        np.testing.assert_array_equal(got, window_features(window, 30.0), err_msg=f"frame {i}")
    win.clear()
    assert len(win) == 0
    with pytest.raises(ValueError, match="no frame"):
        win.features()


def test_one_frames_parts_are_the_windows_rows() -> None:
    seq = _awkward_stream()
    pel, facing = pelvis(seq), facing_vectors(seq)
    for i, frame in enumerate(seq):
        p, f, _, _ = frame_parts(frame)
        np.testing.assert_array_equal(np.array(p), pel[i], err_msg=f"pelvis, frame {i}")
        np.testing.assert_array_equal(np.array(f), facing[i], err_msg=f"facing, frame {i}")
        np.testing.assert_array_equal(np.array(facing_vector(frame)), facing[i], err_msg=f"facing alone, {i}")


@pytest.mark.parametrize("shape", [(16, 3), (17, 2), (2, 17, 3)])
def test_one_frames_parts_need_one_skeleton(shape: tuple[int, ...]) -> None:
    for parts_of in (frame_parts, facing_vector):
        with pytest.raises(ValueError, match=r"shape \(17, 3\)"):
            parts_of(np.zeros(shape))


@pytest.mark.parametrize(
    ("window", "fps", "frame", "match"),
    [
        (1, 30.0, np.zeros((17, 3)), "window"),
        (32, 0.0, np.zeros((17, 3)), "fps"),
        (32, 30.0, np.zeros((16, 3)), r"\(17, 3\)"),
        (32, 30.0, np.zeros((17, 3), np.float32), "float64"),
    ],
)
def test_the_streaming_window_rejects_bad_input(
    window: int, fps: float, frame: np.ndarray, match: str
) -> None:
    with pytest.raises(ValueError, match=match):
        FeatureWindow(window, fps).push(frame)


def test_a_ring_window_holds_the_newest_rows_oldest_first_padded_with_the_first() -> None:
    ring = RingWindow(4, (2,), np.float32)
    with pytest.raises(ValueError, match="no row"):
        ring.view()
    ring.push((1.0, 1.5))
    np.testing.assert_array_equal(ring.view()[:, 0], [1, 1, 1, 1])
    for k in range(2, 8):
        ring.push((k, k + 0.5))
        want = [max(1, i) for i in range(k - 3, k + 1)]
        np.testing.assert_array_equal(ring.view()[:, 0], want, err_msg=f"after {k} rows")
        np.testing.assert_array_equal(ring.view()[:, 1], np.array(want) + 0.5)
    view = ring.view()
    assert view.dtype == np.float32 and view.flags.c_contiguous and len(ring) == 4
    with pytest.raises(ValueError, match="read-only"):
        view[0, 0] = 9.0
    ring.clear()
    assert len(ring) == 0
    ring.push((5.0, 6.0))
    np.testing.assert_array_equal(ring.view(), [[5, 6]] * 4)
    with pytest.raises(ValueError, match="size"):
        RingWindow(0)


def test_the_network_input_with_evidence_is_joint_channels_then_evidence_channels() -> None:
    rng = np.random.default_rng(4)
    feats = window_features(np.stack([_marching(seed=1), _marching(seed=2)]), 30.0)
    ev = rng.normal(size=(2, 32, EVIDENCE_CHANNELS)).astype(np.float32)
    x = to_model_input_v2(feats, ev)
    assert x.shape == (2, NUM_CHANNELS + EVIDENCE_CHANNELS, 32) and x.dtype == np.float32
    assert x.flags.c_contiguous
    np.testing.assert_array_equal(x[:, :NUM_CHANNELS], to_model_input(feats))
    np.testing.assert_array_equal(x[1, NUM_CHANNELS + 3], ev[1, :, 3])
    np.testing.assert_array_equal(to_model_input_v2(feats[0], ev[0]), x[0])
    with pytest.raises(ValueError, match="evidence"):
        to_model_input_v2(feats, ev[:, :31])
