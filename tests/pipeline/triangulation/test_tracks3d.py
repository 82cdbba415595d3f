"""3D tracks: user ids by position and by (camera, track) links, One-Euro, bone-length priors."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.skeleton import J
from pipeline.triangulation.config import Tracks3DParams
from pipeline.triangulation.tracks3d import Candidate, OneEuroFilter, Tracks3D, bone_lengths, bone_outliers
from tests.pipeline.triangulation.scene import skeleton_at


def cand(x: float, y: float, views=()) -> Candidate:
    return Candidate(tuple(views), np.array([x, y, 0.0]))


def test_ids_follow_positions_when_links_are_new() -> None:
    tr = Tracks3D(Tracks3DParams(max_match_distance_m=0.5))
    a, b = tr.assign([cand(0, 0), cand(1, 0)], 0.0)
    assert a != b
    # Both moved a little, reported in the other order, with unknown track ids.
    assert tr.assign([cand(1.1, 0), cand(0.1, 0)], 0.1) == [b, a]
    # Someone appears far from both: a new id.
    c = tr.assign([cand(0.1, 0), cand(1.1, 0), cand(-1, -1)], 0.2)[2]
    assert c not in (a, b)


def test_links_outweigh_a_nearer_position() -> None:
    tr = Tracks3D(Tracks3DParams(max_match_distance_m=0.5))
    a, b = tr.assign([cand(0, 0, [("c1", 1), ("c2", 1)]), cand(0.6, 0, [("c1", 2), ("c2", 2)])], 0.0)
    # The two crossed over: each is now nearer the other's last position, but carries its own links.
    out = tr.assign([cand(0.5, 0, [("c1", 1), ("c2", 1)]), cand(0.1, 0, [("c1", 2), ("c2", 2)])], 0.1)
    assert out == [a, b], "the per-view track links outweigh the positions"
    # Without links, positions decide.
    assert tr.assign([cand(0.5, 0), cand(0.1, 0)], 0.2) == [a, b]
    assert tr.prior_user(("c1", 1)) == a and tr.prior_user(("c9", 1)) == -1


def test_links_and_users_expire() -> None:
    tr = Tracks3D(Tracks3DParams(max_missing_s=1.0), memory_s=2.0)
    (a,) = tr.assign([cand(0, 0, [("c1", 1)])], 0.0)
    tr.assign([], 1.5)
    assert a not in tr.users and tr.prior_user(("c1", 1)) == a
    tr.assign([], 2.5)
    assert tr.prior_user(("c1", 1)) == -1


def test_one_euro_smooths_still_noise_and_follows_motion() -> None:
    rng = np.random.default_rng(0)
    f = OneEuroFilter(min_cutoff_hz=2.0, beta=0.7, d_cutoff_hz=1.0)
    valid = np.ones(17, bool)
    base = skeleton_at(0, 0)
    raw_err, out_err = [], []
    for i in range(60):
        noisy = base + rng.normal(0, 0.01, base.shape)
        out = f(noisy, valid, i / 30)
        if i >= 20:
            raw_err.append(np.abs(noisy - base).mean())
            out_err.append(np.abs(out - base).mean())
    assert np.mean(out_err) < 0.6 * np.mean(raw_err), "still noise must be reduced"
    lag = []
    for i in range(60, 120):  # then walk at 1 m/s along x
        target = base + np.array([(i - 60) / 30, 0, 0])
        out = f(target, valid, i / 30)
        lag.append(target[0, 0] - out[0, 0])
    assert lag[-1] < 0.05, f"steady lag at 1 m/s must stay small (< 5 cm), got {lag[-1]:.3f} m"


def test_one_euro_keeps_unknown_joints_unknown_and_restarts_after_a_gap() -> None:
    f = OneEuroFilter(2.0, 0.7, 1.0)
    base = skeleton_at(0, 0)
    valid = np.ones(17, bool)
    f(base, valid, 0.0)
    valid2 = valid.copy()
    valid2[3] = False
    out = f(np.where(valid2[:, None], base + 0.1, np.nan), valid2, 1 / 30)
    assert np.isnan(out[3]).all() and np.isfinite(out[4]).all()
    out = f(base + 1.0, valid, 5.0)  # after a long gap the filter restarts at the new value
    np.testing.assert_allclose(out, base + 1.0)


def test_bone_outliers_flag_the_distal_joint() -> None:
    x = skeleton_at(0, 0)
    prior = bone_lengths(x)
    valid = np.ones(17, bool)
    assert not bone_outliers(x, valid, prior, 0.35).any()
    y = x.copy()
    y[J["l_wrist"]] += np.array([0.0, 0.3, 0.0])  # forearm suddenly 0.4 m long
    bad = bone_outliers(y, valid, prior, 0.35)
    assert list(np.flatnonzero(bad)) == [J["l_wrist"]]


def test_bone_prior_is_learned_then_used() -> None:
    tr = Tracks3D(Tracks3DParams(bone_prior_s=0.5, smoothing="none"))
    x = skeleton_at(0, 0)
    valid = np.ones(17, bool)
    (uid,) = tr.assign([cand(0, 0)], 0.0)
    for i in range(20):
        tr.assign([cand(0, 0)], i / 30)
        joints, ok = tr.postprocess(uid, x, valid, i / 30)
        assert ok.all()
    assert tr.users[uid].bone_prior_m is not None
    y = x.copy()
    y[J["r_ankle"]] += np.array([0.0, 0.0, -0.3])
    joints, ok = tr.postprocess(uid, y, valid, 1.0)
    assert not ok[J["r_ankle"]] and np.isnan(joints[J["r_ankle"]]).all() and ok.sum() == 16


@pytest.mark.parametrize(("kwargs", "match"), [({"smoothing": "kalman"}, "smoothing"),
                                               ({"max_match_distance_m": 0}, "max_match_distance_m"),
                                               ({"min_valid_joints": 0}, "min_valid_joints")])
def test_bad_track_params_are_rejected(kwargs, match) -> None:
    with pytest.raises(ValueError, match=match):
        Tracks3DParams(**kwargs)


def test_candidate_checks_its_position() -> None:
    with pytest.raises(ValueError, match=r"shape \(3,\)"):
        Candidate((), np.zeros(2))
