"""The SORT box Kalman filter and OC-SORT's observation-centric re-update (ORU)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.tracking.association import associate_iou, associate_ocm, direction_consistency
from pipeline.tracking.kalman import BoxKalmanFilter, box_to_z, z_to_box


@settings(max_examples=50, deadline=None)
@given(x=st.floats(-1000, 3000), y=st.floats(-1000, 3000), w=st.floats(1, 800), h=st.floats(1, 1200))
def test_box_state_round_trip(x: float, y: float, w: float, h: float) -> None:
    box = np.array([x, y, x + w, y + h])
    np.testing.assert_allclose(z_to_box(box_to_z(box)), box, rtol=1e-5, atol=1e-3)


def test_degenerate_state_gives_nan() -> None:
    assert np.isnan(z_to_box(np.array([10.0, 10.0, -5.0, 1.0]))).all()


def box(cx: float, cy: float, w: float = 100.0, h: float = 300.0) -> np.ndarray:
    return np.array([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2])


def test_constant_velocity_is_learned() -> None:
    kf = BoxKalmanFilter(box(100, 500))
    for k in range(1, 30):
        kf.predict()
        kf.update(box(100 + 8 * k, 500 - 2 * k))
    nxt = kf.peek(1)
    np.testing.assert_allclose((nxt[0] + nxt[2]) / 2, 100 + 8 * 30, atol=1.0)
    np.testing.assert_allclose((nxt[1] + nxt[3]) / 2, 500 - 2 * 30, atol=1.0)
    np.testing.assert_allclose(kf.box, kf.peek(0))


def _coast_then_see(kf: BoxKalmanFilter) -> BoxKalmanFilter:
    """Right at 10 px/frame for 20 frames, hidden 10 frames while turning to go down,
    then seen again 100 px below where it was last seen."""
    for k in range(1, 20):
        kf.predict()
        kf.update(box(100 + 10 * k, 500))
    for _ in range(10):
        kf.predict()
    kf.update(box(290, 600))
    return kf


def test_oru_re_runs_the_filter_along_the_virtual_path() -> None:
    """ORU = roll back to the last observation, then predict/update along the straight line
    between the two real observations, one step per frame of the gap."""
    oru = _coast_then_see(BoxKalmanFilter(box(100, 500)))
    ref = BoxKalmanFilter(box(100, 500))
    for k in range(1, 20):
        ref.predict()
        ref.update(box(100 + 10 * k, 500))
    for k in range(1, 11):  # the virtual path (290, 500) -> (290, 600)
        ref.predict()
        ref.update(box(290, 500 + 10 * k))
    np.testing.assert_allclose(oru.x, ref.x, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(oru.P, ref.P, rtol=1e-9, atol=1e-9)
    assert abs(oru.x[0] - 290) < 3 and abs(oru.x[1] - 600) < 3, "the state ends at the new observation"
    assert oru.x[5] > 5.0 and abs(oru.x[4]) < 5.0, f"velocity {oru.x[4:6]} turned downwards"


def test_ocm_prefers_the_detection_in_the_direction_of_motion() -> None:
    prev = np.array([box(100, 500)])
    vel = np.array([[0.0, 1.0]])  # (dy, dx): moving right
    dets = np.array([box(160, 500), box(40, 500)])
    term = direction_consistency(dets, prev, vel, np.array([True]))
    assert term[0, 0] == pytest.approx(0.5, abs=1e-3) and term[1, 0] == pytest.approx(-0.5, abs=1e-3)
    assert (direction_consistency(dets, prev, vel, np.array([False])) == 0).all()


def test_ocm_breaks_an_iou_tie_between_two_tracks() -> None:
    """Two tracks predicted at the same place (crossing): IoU alone cannot tell them apart;
    the direction each has been moving in can."""
    pred = np.array([box(500, 500), box(500, 500)])
    prev = np.array([box(440, 500), box(560, 500)])  # track 0 came from the left, 1 from the right
    vel = np.array([[0.0, 1.0], [0.0, -1.0]])
    dets = np.array([box(480, 500), box(520, 500)])  # det 0 is left of centre, det 1 right
    # det 1 lies further along track 0's direction, det 0 along track 1's
    res = associate_ocm(dets, np.array([0.9, 0.9]), pred, prev, vel, np.array([True, True]), 0.3, 0.2)
    assert sorted(map(tuple, res.matches.tolist())) == [(0, 1), (1, 0)]
    assert res.unmatched_detections.size == 0 and res.unmatched_tracks.size == 0


def test_iou_round_leaves_far_pairs_unmatched() -> None:
    res = associate_iou(np.array([box(100, 500), box(900, 500)]), np.array([box(105, 500)]), 0.3)
    assert res.matches.tolist() == [[0, 0]]
    assert res.unmatched_detections.tolist() == [1] and res.unmatched_tracks.size == 0
    empty = associate_iou(np.zeros((0, 4)), np.array([box(105, 500)]), 0.3)
    assert empty.matches.shape == (0, 2) and empty.unmatched_tracks.tolist() == [0]
