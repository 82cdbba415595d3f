"""The training data pipeline (no training): capture faults, windows, transition weights."""

from __future__ import annotations

import numpy as np

from pipeline.recognition.train import (
    Dataset,
    NoiseConfig,
    capture,
    gather_windows,
    transition_weights,
    window_ends,
)
from pipeline.sim.body import body_from_height
from pipeline.sim.motion import simulate_user
from pipeline.sim.script import MotionScript, Segment


def test_capture_adds_triangulation_like_error_and_unknown_joints() -> None:
    m = simulate_user(MotionScript((Segment("forward", 10.0),)), body_from_height(1.75), 30.0, seed=1)
    out = capture(m.joints_m, np.random.default_rng(0), NoiseConfig(), 30.0)
    assert out.shape == m.joints_m.shape
    err = np.linalg.norm(out - m.joints_m, axis=-1)
    med = float(np.nanmedian(err))
    assert 0.002 < med < 0.05, f"median 3D error {med * 1000:.1f} mm: a few centimetres at most"
    assert np.isnan(out).any(), "some joints are unknown (seen by fewer than two cameras, gaps)"
    again = capture(m.joints_m, np.random.default_rng(0), NoiseConfig(), 30.0)
    np.testing.assert_array_equal(out, again, err_msg="deterministic for a seed")


def test_capture_without_faults_returns_the_skeleton() -> None:
    m = simulate_user(MotionScript((Segment("still", 2.0),)), body_from_height(1.6), 30.0, seed=2)
    quiet = NoiseConfig(
        pixel_sigma_px=(0.0, 0.0),
        drift_sigma_px=(0.0, 0.0),
        drop_prob=(0.0, 0.0),
        outlier_prob=0.0,
        gap_prob_per_s=0.0,
        group_drop_per_s=0.0,
        face_missing_prob=0.0,
    )
    out = capture(m.joints_m, np.random.default_rng(0), quiet, 30.0)
    np.testing.assert_allclose(out, m.joints_m, atol=1e-6)


def _toy() -> Dataset:
    joints = np.arange(10 * 17 * 3, dtype=np.float32).reshape(10, 17, 3)
    labels = np.array([0, 0, 0, 1, 1, 1, 0, 0, 2, 2])
    return Dataset(joints, labels, np.array([0, 6, 10]), 10.0)


def test_windows_repeat_the_first_frame_of_their_own_sequence() -> None:
    data = _toy()
    w = gather_windows(data, np.array([1, 7]), window=4)
    np.testing.assert_array_equal(w[0], data.joints[[0, 0, 0, 1]])
    np.testing.assert_array_equal(
        w[1], data.joints[[6, 6, 6, 7]], err_msg="never reaches into the sequence before"
    )
    assert window_ends(data, stride=3).tolist() == [0, 3, 6, 9]


def test_transition_weights_mark_the_time_after_a_change_but_not_a_new_sequence() -> None:
    w = transition_weights(_toy(), window_s=0.2, weight=2.0)
    assert w.tolist() == [1, 1, 1, 2, 2, 1, 1, 1, 2, 2]
