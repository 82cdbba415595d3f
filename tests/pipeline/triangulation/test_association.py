"""Cross-view association of 2-4 people whose order differs in every view."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.camera import project, undistort_points
from pipeline.errors import InputError
from pipeline.triangulation.association import (
    apply_memory,
    associate,
    cluster_people,
    epipolar_distances,
    essential_matrices,
)
from pipeline.triangulation.config import AssociationParams
from pipeline.triangulation.dlt import CameraRig
from tests.pipeline.triangulation.scene import corner_cameras, skeleton_at

CAMS = corner_cameras()
RIG = CameraRig.from_cameras(CAMS)
CROWD = [skeleton_at(0.0, 0.0), skeleton_at(0.8, 0.5, 90), skeleton_at(-0.7, -0.6, 200),
         skeleton_at(0.5, -0.8, 30)]


def _rows(people, rng, noise_px=1.5):
    """Every person in every camera, each view in its own random order; returns rows + truth."""
    cam_idx, xy, w, truth = [], [], [], []
    for c, cam in enumerate(CAMS):
        for p in rng.permutation(len(people)):
            uv = project(cam, people[p]) + rng.normal(0, noise_px, (17, 2))
            cam_idx.append(c)
            xy.append(undistort_points(cam, uv))
            w.append(np.full(17, 0.9))
            truth.append(int(p))
    return np.array(cam_idx), np.array(xy), np.array(w), np.array(truth)


def test_essential_matrices_satisfy_the_epipolar_constraint() -> None:
    e = essential_matrices(RIG.Rt)
    x = skeleton_at(0.2, 0.1)
    xs = [np.c_[undistort_points(c, project(c, x)), np.ones(17)] for c in CAMS]
    for a in range(4):
        for b in range(4):
            if a != b:
                residual = np.einsum("ni,ij,nj->n", xs[b], e[b, a], xs[a])
                assert np.abs(residual).max() < 1e-9, f"x_{b}' E[{b},{a}] x_{a} must be 0"


@pytest.mark.parametrize("n_people", [1, 2, 3, 4])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_people_in_shuffled_orders_are_grouped_correctly(n_people: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    cam_idx, xy, w, truth = _rows(CROWD[:n_people], rng)
    prior = np.full(len(cam_idx), -1)
    clusters = associate(RIG, cam_idx, xy, w, prior, AssociationParams())
    assert len(clusters) == n_people, f"expected {n_people} people, got clusters {clusters}"
    for members in clusters:
        assert len({truth[m] for m in members}) == 1, f"cluster {members} mixes people {truth[members]}"
        assert len(members) == 4, f"each person is seen by all four cameras, got {members}"


def test_same_camera_pairs_are_never_grouped() -> None:
    rng = np.random.default_rng(5)
    cam_idx, xy, w, _ = _rows(CROWD[:2], rng)
    d = epipolar_distances(RIG, cam_idx, xy, w, 4)
    same = cam_idx[:, None] == cam_idx[None, :]
    assert np.all(np.isinf(d[same])), "people of one camera are not comparable"
    assert np.allclose(d, d.T, equal_nan=True), "the distance is symmetric"


def test_too_few_common_joints_are_not_comparable() -> None:
    rng = np.random.default_rng(6)
    cam_idx, xy, w, _ = _rows(CROWD[:1], rng)
    w[0, 3:] = 0.0  # the first row has only three confident joints
    d = epipolar_distances(RIG, cam_idx, xy, w, 4)
    assert np.all(np.isinf(d[0])) and np.isfinite(d[1, 2])


def test_memory_pulls_known_pairs_together_and_pushes_others_apart() -> None:
    d = np.array([[np.inf, 10.0, 10.0], [10.0, np.inf, 10.0], [10.0, 10.0, np.inf]])
    out = apply_memory(d, np.array([7, 7, 8]), 0.5)
    assert out[0, 1] == 5.0 and out[0, 2] == 20.0 and out[1, 2] == 20.0
    untouched = apply_memory(d, np.array([-1, 7, -1]), 0.5)
    np.testing.assert_array_equal(untouched, d)


def test_clustering_respects_one_person_per_camera() -> None:
    # Three rows, rows 0 and 1 from the same camera, both close to row 2.
    d = np.array([[np.inf, np.inf, 1.0], [np.inf, np.inf, 2.0], [1.0, 2.0, np.inf]])
    clusters = cluster_people(d, np.array([0, 0, 1]), 10.0)
    assert clusters == [[0, 2], [1]]


def test_clustering_rejects_bad_shapes() -> None:
    with pytest.raises(InputError, match="distances must be"):
        cluster_people(np.zeros((2, 3)), np.array([0, 1]), 10.0)
    with pytest.raises(InputError, match="expected xy"):
        epipolar_distances(RIG, np.array([0, 1]), np.zeros((2, 16, 2)), np.ones((2, 17)), 4)
