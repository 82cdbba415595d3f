"""Orientation: yaw_deg of known poses (0 = facing +Y, counter-clockwise positive, (-180, 180])."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pipeline.recognition.orientation import YawSmoother, angle_diff_deg, raw_yaw_deg, wrap_deg
from pipeline.skeleton import J

from .conftest import rot_z, standing_pose

ANGLES = [0.0, 30.0, 90.0, 135.0, 180.0, -45.0, -90.0, -170.0]


@pytest.mark.parametrize("yaw", ANGLES)
def test_yaw_of_a_person_turned_by_a_known_angle(yaw: float) -> None:
    pose = standing_pose() @ rot_z(yaw).T + np.array([0.5, -0.3, 0.0])
    got = raw_yaw_deg(pose)
    assert abs(float(angle_diff_deg(got, yaw))) < 1e-6, f"expected {yaw}, got {got}"
    assert -180.0 < got <= 180.0


def test_named_directions_follow_the_cave_convention() -> None:
    # facing the right wall (+X) is a clockwise turn seen from above: -90
    pose = standing_pose() @ rot_z(-90.0).T
    assert pose[J["l_shoulder"], 1] > 0, "facing +X, the person's left is +Y"
    assert raw_yaw_deg(pose) == pytest.approx(-90.0)
    # facing the left wall (-X): +90; facing the back wall (-Y): 180, never -180
    assert raw_yaw_deg(standing_pose() @ rot_z(90.0).T) == pytest.approx(90.0)
    assert raw_yaw_deg(standing_pose() @ rot_z(180.0).T) == pytest.approx(180.0)


@pytest.mark.parametrize("yaw", ANGLES)
@pytest.mark.parametrize(
    "missing",
    [("l_hip",), ("r_shoulder",), ("l_hip", "l_shoulder"), ("r_hip", "r_shoulder", "r_ear", "r_eye")],
)
def test_yaw_with_a_missing_side(yaw: float, missing: tuple[str, ...]) -> None:
    pose = standing_pose() @ rot_z(yaw).T
    pose[[J[m] for m in missing]] = np.nan
    got = raw_yaw_deg(pose)
    # the whole-side cases fall back to the head, which is less exact
    tol = 1e-6 if len(missing) == 1 else 20.0
    assert abs(float(angle_diff_deg(got, yaw))) < tol, f"{missing} missing: expected {yaw}, got {got}"


def test_nothing_known_gives_nan_and_the_smoother_holds() -> None:
    pose = np.full((17, 3), np.nan)
    assert math.isnan(raw_yaw_deg(pose))
    s = YawSmoother(alpha=0.5, rate_hz=30.0)
    s.update(40.0, 0.0)
    assert s.update(raw_yaw_deg(pose), 1 / 30) == pytest.approx(40.0)


def test_smoother_crosses_plus_minus_180_the_short_way() -> None:
    s = YawSmoother(alpha=0.5, rate_hz=30.0)
    s.update(170.0, 0.0)
    got = s.update(-170.0, 1 / 30)
    assert abs(float(angle_diff_deg(got, 180.0))) < 1.0, f"mean of 170 and -170 is 180, got {got}"


def test_smoother_settles_at_the_same_speed_whatever_the_frame_rate() -> None:
    results = []
    for rate in (15.0, 30.0, 60.0):
        s = YawSmoother(alpha=0.3, rate_hz=30.0)
        s.update(0.0, 0.0)
        for i in range(1, int(rate * 0.2) + 1):
            got = s.update(60.0, i / rate)
        results.append(got)
    assert max(results) - min(results) < 1.5, f"after 0.2 s: {results}"


def test_wrap() -> None:
    np.testing.assert_allclose(
        wrap_deg([180.0, -180.0, 190.0, 540.0, -10.0]), [180.0, 180.0, -170.0, 180.0, -10.0]
    )


@pytest.mark.parametrize(("kwargs", "match"), [({"alpha": 0.0}, "alpha"), ({"rate_hz": -1.0}, "rate_hz")])
def test_bad_smoother_settings(kwargs: dict[str, float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        YawSmoother(**kwargs)


def test_bad_shape() -> None:
    with pytest.raises(ValueError, match=r"\(17, 3\)"):
        raw_yaw_deg(np.zeros((16, 3)))
