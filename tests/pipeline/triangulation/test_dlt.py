"""The pure triangulation math: geometry laws, outlier views, unknown joints, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.camera import project
from pipeline.errors import InputError
from pipeline.triangulation.config import TriangulationParams
from pipeline.triangulation.dlt import CameraRig, reprojection_error, triangulate, triangulate_linear
from tests.pipeline.triangulation.scene import corner_cameras, skeleton_at

CAMS = corner_cameras()
RIG = CameraRig.from_cameras(CAMS)

points_in_cave = st.lists(
    st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(0.05, 2.0)),
    min_size=1,
    max_size=20,
).map(lambda pts: np.array(pts, dtype=np.float64))


def _observe(points: np.ndarray, cams=CAMS) -> np.ndarray:
    return np.stack([project(c, points) for c in cams])


@settings(max_examples=40, deadline=None)
@given(points_in_cave)
def test_project_then_triangulate_returns_the_point(points: np.ndarray) -> None:
    tri = triangulate(RIG, _observe(points))
    assert tri.valid.all(), f"noise-free points must all be valid, got {tri.valid}"
    np.testing.assert_allclose(tri.points_m, points, atol=1e-6, err_msg="triangulation moved the point")
    assert np.all(tri.reproj_px < 1e-3), f"noise-free reprojection error must vanish, got {tri.reproj_px}"


@settings(max_examples=30, deadline=None)
@given(points_in_cave, st.permutations(range(4)), st.integers(0, 2**31 - 1))
def test_reordering_cameras_changes_nothing(points: np.ndarray, order: list[int], seed: int) -> None:
    rng = np.random.default_rng(seed)
    uv = _observe(points) + rng.normal(0.0, 2.0, (4, len(points), 2))
    scores = rng.uniform(0.4, 1.0, (4, len(points)))
    uv[rng.integers(0, 4), 0] += 150.0  # one outlier view for the first point
    ref = triangulate(RIG, uv, scores)
    perm = triangulate(CameraRig.from_cameras([CAMS[i] for i in order]), uv[order], scores[order])
    np.testing.assert_array_equal(perm.valid, ref.valid)
    np.testing.assert_allclose(perm.points_m, ref.points_m, atol=1e-9, equal_nan=True)
    np.testing.assert_array_equal(perm.used, ref.used[order])


def test_noisy_skeleton_is_accurate() -> None:
    rng = np.random.default_rng(3)
    x = skeleton_at(0.3, -0.2, 40)
    tri = triangulate(RIG, _observe(x) + rng.normal(0, 1.5, (4, 17, 2)), np.full((4, 17), 0.9))
    err = np.linalg.norm(tri.points_m - x, axis=1)
    assert err.mean() < 0.01, f"1.5 px noise should give under 1 cm mean error, got {err.mean():.4f} m"


@pytest.mark.parametrize("bad_view", [0, 1, 2, 3])
def test_an_outlier_view_is_dropped_for_that_joint(bad_view: int) -> None:
    rng = np.random.default_rng(bad_view)
    x = skeleton_at(0.0, 0.0)
    uv = _observe(x) + rng.normal(0, 1.0, (4, 17, 2))
    uv[bad_view, 9] += np.array([90.0, -60.0])  # the left wrist is far off in one view
    tri = triangulate(RIG, uv, np.full((4, 17), 0.9))
    assert not tri.used[bad_view, 9], "the bad view must be left out of the wrist"
    assert tri.used[:, :9].all() and tri.used[:, 10:].all(), "good joints keep all views"
    assert np.linalg.norm(tri.points_m[9] - x[9]) < 0.01, "the wrist comes from the three good views"
    plain = triangulate_linear(RIG.Rt, RIG.undistort(uv), np.ones((4, 17)))
    assert np.linalg.norm(plain[9] - x[9]) > 0.02, "without rejection the outlier would pull the wrist"


def test_fewer_than_two_views_is_unknown() -> None:
    x = skeleton_at(0.0, 0.0)
    uv = _observe(x)
    scores = np.full((4, 17), 0.9)
    scores[1:, 0] = 0.0  # nose: one view
    uv[:, 1] = np.nan  # left eye: no view
    scores[:3, 2] = 0.1  # right eye: one confident view, three below the threshold
    tri = triangulate(RIG, uv, scores, TriangulationParams(min_score=0.3))
    assert not tri.valid[:3].any(), f"joints with < 2 views must be unknown, got {tri.valid[:3]}"
    assert np.isnan(tri.points_m[:3]).all() and np.isnan(tri.reproj_px[:3]).all()
    assert tri.valid[3:].all(), "the other joints stay valid"


def test_two_disagreeing_views_are_unknown() -> None:
    x = skeleton_at(0.0, 0.0)
    uv = _observe(x)
    scores = np.zeros((4, 17))
    scores[:2] = 0.9
    uv[0, 5] += 200.0
    tri = triangulate(RIG, uv, scores, TriangulationParams(max_reproj_px=20.0))
    assert not tri.valid[5], "two views that disagree by far more than max_reproj_px give no point"
    assert tri.valid[6], "an agreeing pair is fine"


def test_rig_projection_matches_the_camera_model() -> None:
    x = skeleton_at(0.5, 0.5, 120)
    np.testing.assert_allclose(RIG.project(x), _observe(x), atol=1e-9)


def test_reprojection_error_is_the_pixel_distance() -> None:
    x = skeleton_at(0.0, 0.0)
    uv = _observe(x)
    uv[2, 4] += np.array([3.0, 4.0])
    err = reprojection_error(CAMS, x, uv)
    assert err.shape == (4, 17)
    assert err[2, 4] == pytest.approx(5.0, abs=1e-9)
    assert np.count_nonzero(err > 1e-9) == 1


@pytest.mark.parametrize(
    ("uv_shape", "score_shape", "match"),
    [
        ((3, 17, 2), (3, 17), r"expected shape \(4, N, 2\)"),
        ((4, 17, 3), (4, 17), r"expected shape \(4, N, 2\)"),
        ((4, 17), (4, 17), r"expected shape \(4, N, 2\)"),
        ((4, 17, 2), (4, 16), r"scores: expected shape \(4, 17\)"),
    ],
)
def test_bad_shapes_are_rejected(uv_shape, score_shape, match) -> None:
    with pytest.raises(InputError, match=match):
        triangulate(RIG, np.zeros(uv_shape), np.ones(score_shape))


def test_good_shapes_do_not_raise() -> None:
    tri = triangulate(RIG, np.full((4, 0, 2), np.nan))
    assert tri.points_m.shape == (0, 3)
    tri = triangulate(RIG, np.full((4, 3, 2), np.nan), None)
    assert tri.points_m.shape == (3, 3) and not tri.valid.any()


def test_rig_rejects_duplicate_names() -> None:
    with pytest.raises(InputError, match="unique"):
        CameraRig.from_cameras([CAMS[0], CAMS[0]])
    with pytest.raises(InputError, match="at least one camera"):
        CameraRig.from_cameras([])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"min_score": 1.5}, "min_score"),
        ({"outlier_ratio": 1.0}, "outlier_ratio"),
        ({"max_reproj_px": 0.0}, "max_reproj_px"),
        ({"refine_iterations": -1}, "refine_iterations"),
    ],
)
def test_bad_params_are_rejected(kwargs, match) -> None:
    with pytest.raises(ValueError, match=match):
        TriangulationParams(**kwargs)


def test_the_outlier_floor_scales_with_the_person_size() -> None:
    rng = np.random.default_rng(7)
    x = skeleton_at(0.0, 0.0)
    uv = _observe(x) + rng.normal(0, 1.0, (4, 17, 2))
    uv[1, 13] += np.array([40.0, 0.0])  # 40 px off: gross for a 200 px person, noise for a 1000 px one
    scores = np.full((4, 17), 0.9)
    small = triangulate(
        RIG, uv, scores, TriangulationParams(outlier_min_frac=0.1), scale_px=np.full((4, 17), 200.0)
    )
    large = triangulate(
        RIG, uv, scores, TriangulationParams(outlier_min_frac=0.1), scale_px=np.full((4, 17), 1000.0)
    )
    assert not small.used[1, 13], "40 px is 20 % of a 200 px person: an outlier"
    assert large.used[1, 13], "40 px is 4 % of a 1000 px person: kept"
    with pytest.raises(InputError, match="scale_px"):
        triangulate(RIG, uv, scores, scale_px=np.ones((4, 16)))
