"""The evaluation measures on small hand-made label sequences with known answers."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.recognition.metrics import (
    angle_error_deg,
    confusion,
    latencies,
    macro_f1,
    text_confusion,
    text_histogram,
    transition_mask,
)

S, F, L, R = 0, 1, 2, 3


def test_latencies_of_starts_and_stops() -> None:
    truth = np.array([S] * 10 + [F] * 10 + [S] * 10 + [L] * 5)
    pred = np.array([S] * 13 + [F] * 8 + [S] * 9 + [S] * 5)  # start 3 frames late, stop 1 late, L never
    lat = latencies(truth, pred, fps=10.0)
    np.testing.assert_allclose(lat.start_s[:1], [0.3])
    assert np.isnan(lat.start_s[1]), "the last onset is never detected"
    np.testing.assert_allclose(lat.stop_s, [0.1])


def test_a_change_between_moving_classes_is_no_start() -> None:
    truth = np.array([S] * 5 + [F] * 5 + [L] * 5 + [S] * 5)
    pred = truth.copy()
    lat = latencies(truth, pred, fps=10.0)
    assert lat.start_s.tolist() == [0.0] and lat.stop_s.tolist() == [0.0]


def test_transition_mask_leaves_out_the_time_after_each_change() -> None:
    truth = np.array([S] * 5 + [F] * 5)
    keep = transition_mask(truth, fps=10.0, exclude_s=0.3)
    assert keep.tolist() == [True] * 5 + [False] * 3 + [True] * 2


def test_confusion_and_macro_f1() -> None:
    truth = np.array([S, S, S, F, F, L, R])
    pred = np.array([S, S, F, F, F, L, S])
    conf = confusion(truth, pred)
    assert conf[S, S] == 2 and conf[S, F] == 1 and conf[R, S] == 1 and conf.sum() == 7
    # F1: still 2*2/(4+1+1)=0.667, forward 2*2/(4+1)=0.8, left 1.0, right 0
    assert macro_f1(conf) == pytest.approx((2 / 3 + 0.8 + 1.0 + 0.0) / 4)
    assert macro_f1(confusion(truth, truth)) == 1.0
    assert "recall" in text_confusion(conf) and "still" in text_confusion(conf)


def test_angle_error_wraps() -> None:
    np.testing.assert_allclose(
        angle_error_deg([179.0, -90.0, 10.0], [-179.0, 90.0, 350.0]), [2.0, 180.0, 20.0]
    )


def test_text_histogram_counts_and_misses() -> None:
    text = text_histogram(np.array([0.05, 0.15, 0.16, np.nan]), [0.0, 0.1, 0.2])
    lines = text.splitlines()
    assert lines[0].endswith(" 1") and lines[1].endswith(" 2") and lines[2].endswith(" 0")
    assert "never detected within the segment: 1" in text
