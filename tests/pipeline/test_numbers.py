"""`pipeline.numbers.rounded`: what every stage's to_dict writes for a float (JSON has no NaN)."""

from __future__ import annotations

import json
import math

import numpy as np

from pipeline.numbers import rounded
from pipeline.recognition.steps import StepTracker
from pipeline.skeleton import NUM_JOINTS


def test_rounded_keeps_finite_numbers_and_drops_the_rest() -> None:
    assert rounded(1.23456) == 1.235
    assert rounded(np.float32(2.5), 1) == 2.5
    assert rounded(-0.00004, 4) == -0.0
    assert rounded(None) is None
    assert rounded(math.nan) is None
    assert rounded(-math.inf) is None


def test_a_step_frame_with_unknown_feet_is_strict_json() -> None:
    frame = StepTracker().update(np.full((NUM_JOINTS, 3), np.nan), 0.0)  # nothing seen yet
    text = json.dumps(frame.to_dict(), allow_nan=False)  # raises on NaN or infinity
    feet = json.loads(text)["feet"]
    assert [f["height_m"] for f in feet] == [None, None]
