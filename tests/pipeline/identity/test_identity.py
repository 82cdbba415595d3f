"""Re-identification from body measurements: the measures, the gallery's decision, and user ids
that survive an exit and a swap of the cameras' track ids in the 3D tracks."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.identity.body import MEASURES, body_measures, measure_distance, signature
from pipeline.identity.config import IdentityConfig
from pipeline.identity.gallery import Gallery, LostUser
from pipeline.sim.body import body_from_height
from pipeline.sim.motion import simulate_user
from pipeline.sim.script import MotionScript, Segment
from pipeline.triangulation.config import Tracks3DParams
from pipeline.triangulation.tracks3d import Candidate, Tracks3D


def walking(height_m: float, seed: int = 0) -> np.ndarray:
    script = MotionScript((Segment("forward", 3.0, travel_mps=0.8), Segment("still", 1.0)))
    return simulate_user(script, body_from_height(height_m), fps=30.0, seed=seed).joints_m


def test_body_measures_stay_while_a_person_moves_and_tell_people_apart() -> None:
    tall, short = walking(1.85), walking(1.65, seed=1)
    m_tall = np.array([body_measures(j) for j in tall])
    assert m_tall.shape == (len(tall), len(MEASURES)) and np.all(np.isfinite(m_tall))
    assert np.max(np.std(m_tall, axis=0)) < 0.01, "bone lengths and stature do not change with the gait"
    sig_tall, sig_short = signature(m_tall), signature(np.array([body_measures(j) for j in short]))
    assert measure_distance(sig_tall, signature(m_tall[::3])) < 0.003
    assert measure_distance(sig_tall, sig_short) > 0.03, "20 cm of stature apart"
    stature = sig_tall[MEASURES.index("stature")]
    assert 0.925 * 1.85 - 0.1 < stature < 0.925 * 1.85 + 0.1, f"ear height standing straight, got {stature}"


def test_unknown_joints_leave_measures_unknown_and_too_few_are_not_compared() -> None:
    joints = walking(1.75)[0].copy()
    valid = np.ones(17, dtype=bool)
    valid[[13, 14, 15, 16]] = False  # knees and ankles hidden
    m = body_measures(joints, valid)
    assert np.isnan(m[MEASURES.index("thigh")]) and np.isnan(m[MEASURES.index("stature")])
    assert np.isfinite(m[MEASURES.index("upper_arm")])
    few = np.full(len(MEASURES), np.nan)
    few[:3] = m[:3]
    assert measure_distance(few, m) == float("inf")


def lost(uid: int, height: float, t: float, xy: tuple[float, float] = (0.0, 0.0)) -> LostUser:
    return LostUser(
        uid, signature(np.array([body_measures(j) for j in walking(height)[:20]])), t, np.array([*xy, 0.0])
    )


@pytest.mark.parametrize(
    ("height", "first_seen", "where", "expect", "why"),
    [
        (1.80, 10.0, (1.0, 0.0), 1, "body within"),
        (1.65, 10.0, (1.0, 0.0), None, "nearest body differs"),
        (1.80, 4.5, (1.0, 0.0), None, "nobody lost"),  # seen after user 1 was lost: not them
        (1.80, 5.2, (5.0, 0.0), None, "nobody lost"),  # 5 m in 0.2 s: out of reach
        (1.72, 10.0, (1.0, 0.0), None, "ambiguous"),
    ],  # as close to user 2 as to user 1
)
def test_the_gallery_matches_one_body_within_reach(
    height: float, first_seen: float, where: tuple[float, float], expect: int | None, why: str
) -> None:
    g = Gallery(IdentityConfig())
    g.add(lost(1, 1.80, 5.0))
    g.add(lost(2, 1.50, 5.0))
    if why == "ambiguous":
        g.lost.clear()
        g.add(lost(1, 1.71, 5.0))
        g.add(lost(2, 1.73, 5.0))
    sig = signature(np.array([body_measures(j) for j in walking(height, seed=4)[:20]]))
    best, reason = g.match(sig, first_seen, np.array([*where, 0.0]))
    assert (None if best is None else best.user_id) == expect and why in reason, reason


def candidates_of(joints: np.ndarray, xy: np.ndarray, views: tuple[tuple[str, int], ...]) -> Candidate:
    return Candidate(views, np.array([xy[0], xy[1], 0.0]), body_measures(joints))


@pytest.mark.parametrize("enabled", [True, False])
def test_a_person_who_leaves_and_comes_back_keeps_their_id(enabled: bool) -> None:
    tracks = Tracks3D(Tracks3DParams(max_missing_s=2.0), identity=IdentityConfig(enabled=enabled))
    a, b = walking(1.85), walking(1.62, seed=2)
    ids_a, ids_b = [], []
    for k in range(300):  # 10 s; A is away from 3 s to 7 s and comes back elsewhere with new 2D ids
        t = k / 30
        cands = [candidates_of(b[k % len(b)], np.array([-1.0, 0.0]), (("cam1", 2), ("cam2", 2)))]
        away = 90 <= k < 210
        if not away:
            xy = np.array([0.8, 0.5]) if k < 90 else np.array([0.2, -0.9])
            tid = 1 if k < 90 else 7
            cands.insert(0, candidates_of(a[k % len(a)], xy, (("cam1", tid), ("cam2", tid))))
        out = tracks.assign(cands, t)
        if not away:
            ids_a.append(out[0])
        ids_b.append(out[-1])
    assert set(ids_b) == {ids_b[0]}, "the one who stayed keeps their id"
    back = ids_a[90:]
    if enabled:
        assert back[-1] == ids_a[0], f"A is re-identified: ids after the return {sorted(set(back))}"
        assert sum(u == ids_a[0] for u in back) >= len(back) - 30, "within a second of the return"
    else:
        assert set(back) == {back[0]} and back[0] != ids_a[0], "without identity: a new id"


def test_people_whose_2d_tracks_swap_as_they_cross_keep_their_ids() -> None:
    """A and B walk past each other along x; at the crossing every camera's tracker swaps their
    track ids (what OC-SORT does when two people overlap): the bodies keep the 3D ids."""
    results = {}
    for weight in (1.0, 0.0):
        tracks = Tracks3D(Tracks3DParams(), identity=IdentityConfig(body_weight=weight))
        a, b = walking(1.88), walking(1.60, seed=3)
        got_a = []
        for k in range(120):
            t = k / 30
            xa, xb = -1.0 + k / 60, 1.0 - k / 60  # cross at k = 60
            ta, tb = (1, 2) if k < 60 else (2, 1)
            cands = [
                Candidate((("cam1", ta), ("cam2", ta)), np.array([xa, 0.15, 0.0]), body_measures(a[k])),
                Candidate((("cam1", tb), ("cam2", tb)), np.array([xb, -0.15, 0.0]), body_measures(b[k])),
            ]
            got_a.append(tracks.assign(cands, t)[0])
        results[weight] = got_a
    assert set(results[1.0]) == {results[1.0][0]}, "with the body term A keeps their id through the swap"
    assert len(set(results[0.0])) == 2, "from the 2D tracks alone the ids swap (what the body term fixes)"


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"window_s": 0.0}, "window_s"),
        ({"decide_s": 0.1}, "decide_s"),
        ({"ambiguity_ratio": 0.5}, "ambiguity_ratio"),
        ({"max_distance_m": 0.0}, "max_distance_m"),
        ({"body_weight": -1.0}, "body_weight"),
    ],
)
def test_bad_identity_config_is_refused(kwargs: dict[str, float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        IdentityConfig(**kwargs)
