"""The TRC export's pure parts: resampling to a uniform rate, the Y-up axes, refused shapes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from pipeline.errors import InputError
from pipeline.takes.export import resample, trc_text


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(0.01, 0.08), min_size=3, max_size=30), st.sampled_from([10.0, 30.0, 60.0]))
@example([0.02, 0.02, 0.02666665821097235], 30.0)  # a span 8.5e-9 s short of two samples (a CI found it)
def test_resampling_a_linear_motion_gives_the_line_at_the_grid_times(steps: list[float], rate: float) -> None:
    t = np.concatenate([[0.2], 0.2 + np.cumsum(steps)])
    joints = np.stack([np.full((17, 3), 0.0) + np.array([1.0, -2.0, 0.5]) * x for x in t]).astype(np.float64)
    grid, out = resample(joints, t, rate)
    assert grid[0] == t[0] and grid[-1] <= t[-1] + 1e-9 and len(grid) == int((t[-1] - t[0]) * rate + 1e-9) + 1
    np.testing.assert_allclose(np.diff(grid), 1 / rate, atol=1e-9)
    np.testing.assert_allclose(out[:, 0], grid[:, None] * np.array([1.0, -2.0, 0.5]), atol=1e-9)


def test_a_grid_time_beside_an_unknown_frame_is_unknown_and_one_on_a_known_frame_is_kept() -> None:
    t = np.array([0.0, 0.1, 0.2, 0.3])
    joints = np.zeros((4, 17, 3))
    joints[:, :, 0] = [[0.0], [1.0], [2.0], [3.0]]
    joints[2, 5] = np.nan
    grid, out = resample(joints, t, 20.0)
    assert np.allclose(grid, [0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3])
    x = out[:, 5, 0]
    assert np.allclose(x[[0, 1, 2, 6]], [0.0, 0.5, 1.0, 3.0]) and np.isnan(x[[3, 4, 5]]).all(), x


def test_trc_rows_are_y_up_and_unknown_values_empty() -> None:
    joints = np.zeros((2, 17, 3))
    joints[:, 0] = [1.0, 2.0, 3.0]  # x right, y front, z up
    joints[1, 1] = np.nan
    text = trc_text(joints, np.array([0.0, 0.1]), "a.trc", 10.0).splitlines()
    row = text[5].split("\t")
    assert row[:5] == ["1", "0.00000", "2.00000", "3.00000", "1.00000"], row
    assert text[6].split("\t")[5:8] == ["", "", ""]


@pytest.mark.parametrize(
    ("joints", "rate", "match"),
    [(np.zeros((3, 16, 3)), 30.0, r"shape \(T, 17, 3\)"), (np.zeros((3, 17, 3)), 0.0, "rate must be")],
)
def test_bad_trc_input_is_refused(joints: np.ndarray, rate: float, match: str) -> None:
    with pytest.raises(InputError, match=match):
        trc_text(joints, np.arange(3) / 30, "x.trc", rate)
