"""OC-SORT on scripted scenarios, with the ids the published algorithm defines.

The expected ids follow from OC-SORT's definition (Cao et al. 2023; noahcao/OC_SORT):
ids are given in birth order from 1; a track is reported only while matched this frame
and after ``min_hits`` consecutive matches (or in the first ``min_hits`` frames); a
track unmatched for more than ``max_age`` frames dies; a track seen again after a gap
restarts its hit streak.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pipeline.pose.types import ViewDetections
from pipeline.tracking.ocsort import MultiViewTracker, OCSort, OCSortConfig
from pipeline.tracking.types import TrackedView
from tests.pipeline.tracking.scenario import box_at, frame, tag


def run(tracker: OCSort, frames: list[ViewDetections]) -> list[TrackedView]:
    return [tracker.update(f) for f in frames]


def ids_of(out: TrackedView) -> dict[int, int]:
    """Reported track id -> scripted person (read from the keypoints that rode along)."""
    people = np.round((out.keypoint_scores[:, 0] - 0.5) / 0.01).astype(int)
    return {int(t): int(p) for t, p in zip(out.track_ids, people, strict=True)}


def test_crossing_with_occlusion_keeps_both_ids() -> None:
    """A walks right in front, B walks left behind; B is hidden while they overlap."""
    rng = np.random.default_rng(1)
    frames, hidden = [], []
    for k in range(60):
        xa, xb = 300 + 15 * k, 1200 - 15 * k
        a = box_at(xa, 540)
        b = box_at(xb, 520, 90, 270)  # a bit further away: smaller and higher in the image
        occluded = abs(xa - xb) < 130
        hidden.append(occluded)
        frames.append(frame(k, [(1, a)] + ([] if occluded else [(2, b)]), rng))
    assert 5 <= sum(hidden) <= 12, "the scenario has a real occlusion"
    out = run(OCSort(OCSortConfig()), frames)
    back = hidden.index(True) + sum(hidden)  # first frame B is visible again
    for k, o in enumerate(out):
        expected = {1: 1}
        if not hidden[k] and k not in (back, back + 1):  # B needs min_hits=3 matches again
            expected[2] = 2
        assert ids_of(o) == expected, f"frame {k}: got {ids_of(o)}, expected {expected}"


def test_ocr_recovers_a_track_that_stopped_while_hidden() -> None:
    """A person walks right, stops behind an obstacle, and reappears where last seen: the
    Kalman prediction has run on (IoU below threshold), the last observation has not."""
    frames = []
    for k in range(40):
        x = 300 + 15 * min(k, 20)
        frames.append(frame(k, [] if 21 <= k <= 26 else [(1, box_at(x, 540))]))
    tracker = OCSort(OCSortConfig())
    out = run(tracker, frames)
    assert all(ids_of(o) == {} for o in out[21:29]), "hidden, then re-confirming (min_hits)"
    assert all(ids_of(o) == {1: 1} for o in out[29:]), "the same id after the stop"
    assert [t.track_id for t in tracker.tracks] == [1], "no second track was born"


def test_ocr_off_would_split_the_track() -> None:
    """The same scene with OCR's IoU gate made impossible shows the recovery was OCR's doing."""
    frames = []
    for k in range(40):
        x = 300 + 15 * min(k, 20)
        frames.append(frame(k, [] if 21 <= k <= 26 else [(1, box_at(x, 540))]))
    tracker = OCSort(OCSortConfig(iou_threshold=0.99))  # stricter than any match allows
    run(tracker, frames)
    assert len({t.track_id for t in tracker.tracks}) >= 2, "without recovery a new id is born"


@pytest.mark.parametrize(("gap", "same_id"), [(30, True), (31, False)])
def test_a_track_dies_after_max_age(gap: int, same_id: bool) -> None:
    frames = [frame(k, [(1, box_at(500, 540))]) for k in range(10)]
    frames += [frame(10 + k, []) for k in range(gap)]
    frames += [frame(10 + gap + k, [(1, box_at(500, 540))]) for k in range(5)]
    out = run(OCSort(OCSortConfig(max_age=30)), frames)
    expected_id = 1 if same_id else 2
    assert list(ids_of(out[-1])) == [expected_id]


def test_min_hits_delays_reporting_a_newcomer() -> None:
    frames = [frame(k, [(1, box_at(400, 540))] + ([(2, box_at(1200, 540))] if k >= 10 else []))
              for k in range(16)]
    out = run(OCSort(OCSortConfig(min_hits=3)), frames)
    assert ids_of(out[0]) == {1: 1}, "reported at once in the first min_hits frames"
    assert all(ids_of(out[k]) == {1: 1} for k in (10, 11, 12)), "birth + 2 matches: not yet"
    assert ids_of(out[13]) == {1: 1, 2: 2}, "reported once min_hits matches follow the birth"


def test_keypoints_ride_along_and_history_is_kept() -> None:
    rng = np.random.default_rng(7)
    frames = [frame(k, [(p, box_at(300 + 400 * p + 3 * k, 540)) for p in range(4)], rng) for k in range(50)]
    tracker = OCSort(OCSortConfig(history=8))
    first: dict[int, int] = {}
    for f in frames:
        out = tracker.update(f)
        m = ids_of(out)
        first = first or m
        assert len(m) == 4 and len(set(m.values())) == 4
        for i, row in enumerate(out.detection_index):
            np.testing.assert_array_equal(out.keypoints_xy[i], f.keypoints_xy[row])
            np.testing.assert_array_equal(out.boxes_xyxy[i], f.boxes_xyxy[row])
    assert m == first, "every person keeps the id it got in the first frame"
    assert sorted(m) == [1, 2, 3, 4], "ids 1.. in birth order"
    for t in tracker.tracks:
        assert len(t.history) == 8, "the history is bounded"
        assert [o.frame_index for o in t.history] == list(range(42, 50))
        assert np.all(t.history[-1].keypoint_scores == np.float32(tag(m[t.track_id])))


def test_low_scores_neither_match_nor_start_tracks() -> None:
    tracker = OCSort(OCSortConfig(det_thresh=0.5))
    low = frame(0, [(1, box_at(900, 540))], score=0.2)
    both = ViewDetections(
        "cam01", 1, 0.0, low.image_size,
        np.concatenate([low.boxes_xyxy, frame(1, [(2, box_at(300, 540))]).boxes_xyxy]),
        np.array([0.2, 0.9], np.float32),
        np.concatenate([low.keypoints_xy, frame(1, [(2, box_at(300, 540))]).keypoints_xy]),
        np.concatenate([low.keypoint_scores, frame(1, [(2, box_at(300, 540))]).keypoint_scores]),
    )
    assert len(tracker.update(low)) == 0
    out = tracker.update(both)
    assert out.detection_index.tolist() == [1], "detection_index points at the original row"
    assert ids_of(out) == {1: 2}


def test_predicted_boxes_follow_the_motion() -> None:
    tracker = OCSort(OCSortConfig())
    for k in range(15):
        tracker.update(frame(k, [(1, box_at(300 + 10 * k, 540))]))
    pred = tracker.predicted_boxes()
    assert list(pred) == [1]
    cx = (pred[1][0] + pred[1][2]) / 2
    assert abs(cx - (300 + 10 * 15)) < 3.0, f"next centre {cx:.1f}, expected about 450"
    assert tracker.last_matched == frozenset({1})


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"det_thresh": 1.5}, "det_thresh"),
        ({"iou_threshold": -0.1}, "iou_threshold"),
        ({"max_age": 0}, "max_age"),
        ({"delta_t": 0}, "delta_t"),
        ({"history": 0}, "history"),
        ({"inertia": -1.0}, "inertia"),
    ],
)
def test_config_rejects_bad_values(changes: dict[str, float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        replace(OCSortConfig(), **changes)  # type: ignore[arg-type]


def test_multiview_tracker_keeps_cameras_apart() -> None:
    mv = MultiViewTracker(["cam01", "cam02"])
    for k in range(5):
        views = mv.update([
            frame(k, [(1, box_at(300, 540))], camera="cam02"),
            frame(k, [(1, box_at(300, 540)), (2, box_at(900, 540))], camera="cam01"),
        ])
    assert [v.camera for v in views] == ["cam01", "cam02"], "results in camera order"
    assert views[0].track_ids.tolist() == [1, 2] and views[1].track_ids.tolist() == [1]
    with pytest.raises(ValueError, match="one per known camera"):
        mv.update([frame(5, [], camera="cam09")])
    with pytest.raises(ValueError, match="unique"):
        MultiViewTracker(["a", "a"])


def test_predicted_boxes_only_for_tracks_seen_last_frame() -> None:
    tracker = OCSort(OCSortConfig(min_hits=3))
    for k in range(5):
        tracker.update(frame(k, [(1, box_at(300, 540)), (2, box_at(900, 540))] if k < 4 else
                             [(1, box_at(300, 540))]))
    assert list(tracker.predicted_boxes()) == [1], "person 2 was not seen in the last frame"
    tracker.update(frame(5, [(1, box_at(300, 540)), (3, box_at(1500, 540))]))
    assert list(tracker.predicted_boxes()) == [1], "the newcomer is not confirmed yet"
    assert sorted(tracker.predicted_boxes(confirmed_only=False)) == [1, 3]
