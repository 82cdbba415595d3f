"""MultiViewGrouper: newest-frame grouping by capture time with a tolerance."""

from __future__ import annotations

import pytest

from pipeline.sources.grouper import FrameRef, GrouperConfig, MultiViewGrouper

CAMS = ["cam01", "cam02", "cam03"]


def offer_all(g: MultiViewGrouper, seq: int, ts: dict[str, float], now: float) -> None:
    for cam, t in ts.items():
        g.offer(FrameRef(cam, seq, t), now)


def test_groups_frames_within_tolerance() -> None:
    g = MultiViewGrouper(CAMS, GrouperConfig(tolerance_s=0.01, max_wait_s=0.02))
    offer_all(g, 0, {"cam01": 1.000, "cam02": 1.004, "cam03": 1.008}, now=1.01)
    group = g.poll(1.01)
    assert group is not None, "three frames within 10 ms must form a group"
    assert [m.camera for m in group.members] == CAMS
    assert group.missing == ()
    assert group.timestamp_s == pytest.approx(1.000)
    assert g.poll(1.011) is None, "the same frames must not be grouped twice"


def test_waits_for_a_late_camera_then_goes_without_it() -> None:
    g = MultiViewGrouper(CAMS, GrouperConfig(tolerance_s=0.01, max_wait_s=0.02, gone_after_s=1.0))
    offer_all(g, 0, {"cam01": 0.0, "cam02": 0.0, "cam03": 0.0}, now=0.0)
    assert g.poll(0.0) is not None
    offer_all(g, 1, {"cam01": 0.1, "cam02": 0.1}, now=0.1)
    assert g.poll(0.105) is None, "cam03 is alive and only 5 ms late: wait"
    group = g.poll(0.125)
    assert group is not None, "after max_wait_s the others go on"
    assert group.missing == ("cam03",)
    assert {m.camera for m in group.members} == {"cam01", "cam02"}


def test_a_gone_camera_is_not_waited_for() -> None:
    g = MultiViewGrouper(CAMS, GrouperConfig(tolerance_s=0.01, max_wait_s=0.5, gone_after_s=0.2))
    offer_all(g, 0, {"cam01": 0.0, "cam02": 0.0, "cam03": 0.0}, now=0.0)
    g.poll(0.0)
    offer_all(g, 5, {"cam01": 1.0, "cam02": 1.0}, now=1.0)
    group = g.poll(1.0)
    assert group is not None, "cam03 silent for 1 s (> gone_after_s) must not hold the group"
    assert group.missing == ("cam03",)
    assert g.alive(1.0) == ["cam01", "cam02"]


def test_stale_frame_outside_tolerance_is_left_out_and_skips_counted() -> None:
    g = MultiViewGrouper(CAMS, GrouperConfig(tolerance_s=0.01, max_wait_s=0.0))
    g.offer(FrameRef("cam01", 3, 2.00), 2.0)
    g.offer(FrameRef("cam02", 7, 2.003), 2.0)
    g.offer(FrameRef("cam03", 1, 1.50), 2.0)
    group = g.poll(2.01)
    assert group is not None
    assert {m.camera for m in group.members} == {"cam01", "cam02"}, "cam03's frame is 0.5 s older"
    assert group.skipped == {"cam01": 3, "cam02": 7}, "frames 0..seq-1 were never used"


def test_older_offers_are_ignored() -> None:
    g = MultiViewGrouper(["a"], GrouperConfig(max_wait_s=0.0))
    g.offer(FrameRef("a", 5, 1.0), 1.0)
    g.offer(FrameRef("a", 4, 0.9), 1.0)
    group = g.poll(1.0)
    assert group is not None and group.members[0].seq == 5


@pytest.mark.parametrize(
    ("cameras", "match"),
    [([], "at least one camera"), (["a", "a"], "unique")],
)
def test_bad_camera_lists(cameras: list[str], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        MultiViewGrouper(cameras)


def test_unknown_camera_rejected_and_state_unchanged() -> None:
    g = MultiViewGrouper(["a"], GrouperConfig(max_wait_s=0.0))
    with pytest.raises(ValueError, match="unknown camera 'b'"):
        g.offer(FrameRef("b", 0, 0.0), 0.0)
    assert g.poll(0.0) is None, "a rejected offer must not create a group"


@pytest.mark.parametrize("field", ["tolerance_s", "max_wait_s", "gone_after_s"])
def test_negative_config_rejected(field: str) -> None:
    with pytest.raises(ValueError, match=field):
        GrouperConfig(**{field: -1.0})
