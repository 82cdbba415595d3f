"""The ROI scheduler: when it crops, where, and when it falls back to the full frame."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pipeline.pose.roi import RoiConfig, RoiScheduler, crop_region, merge_regions, with_margin

SIZES = [(1080, 1920), (1080, 1920)]


def person(cx: float = 540, cy: float = 900, w: float = 300, h: float = 800) -> np.ndarray:
    return np.array([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2])


def test_first_frame_is_full_then_crops_per_track() -> None:
    sched = RoiScheduler(RoiConfig())
    plan = sched.plan(SIZES, [{}, {}])
    assert plan.full and plan.reason == "first frame" and plan.net_size is None
    assert plan.jobs == ((0, None), (1, None))
    sched.report(full=True, lost_track=False)
    plan = sched.plan(SIZES, [{1: person(), 2: person(200, 900, 150, 500)}, {1: person()}])
    assert not plan.full
    assert [i for i, _ in plan.jobs] == [0, 0, 1], "one crop per tracked person, all views in one batch"
    assert plan.net_size is not None and plan.net_size[1] == 320
    for _, region in plan.jobs:
        assert region is not None
        x1, y1, x2, y2 = region
        assert (x2 - x1) / (y2 - y1) == pytest.approx(plan.net_size[0] / plan.net_size[1]), "no padding waste"


def test_a_view_without_tracks_is_looked_at_whole() -> None:
    sched = RoiScheduler(RoiConfig())
    sched.report(full=True, lost_track=False)
    plan = sched.plan(SIZES, [{1: person()}, {}])
    assert not plan.full and plan.jobs[1] == (1, None)


@pytest.mark.parametrize(
    ("config", "lost", "frames_since_full", "reason"),
    [
        (RoiConfig(enabled=False), False, 1, "roi off"),
        (RoiConfig(full_every=5), False, 5, "periodic"),  # frames 0 and 5 full, 1-4 crops
        (RoiConfig(full_every=5), True, 1, "track lost"),
        (RoiConfig(max_crops=1), False, 1, "too many crops"),
    ],
)
def test_falls_back_to_the_full_frame(
    config: RoiConfig, lost: bool, frames_since_full: int, reason: str
) -> None:
    sched = RoiScheduler(config)
    for k in range(frames_since_full):
        sched.report(full=k == 0, lost_track=lost and k == frames_since_full - 1)
    plan = sched.plan(SIZES, [{1: person()}, {1: person()}])
    assert plan.full and plan.reason == reason


def test_nobody_tracked_means_full_frames() -> None:
    sched = RoiScheduler(RoiConfig())
    sched.report(full=True, lost_track=False)
    assert sched.plan(SIZES, [{}, {}]).reason == "nobody tracked"


def test_crop_region_contains_the_box_with_margin_and_stays_in_the_image() -> None:
    b = person(100, 500, 200, 600)  # near the left edge
    region = with_margin(b, 0.1)
    assert region == pytest.approx((-60, 140, 260, 860))
    net = RoiConfig().net_size([region])
    x1, y1, x2, y2 = crop_region(region, (1080, 1920), net)
    assert x1 >= 0 and y1 >= 0 and x2 <= 1080 and y2 <= 1920, "shifted into the image"
    assert x1 <= b[0] and y1 <= b[1] - 60 + 1e-6 and x2 >= b[2] and y2 >= b[3] + 60 - 1e-6
    huge = crop_region(with_margin(person(540, 960, 1080, 1920), 0.1), (1080, 1920), net)
    assert (huge[0] + huge[2]) / 2 == pytest.approx(540) and (huge[1] + huge[3]) / 2 == pytest.approx(960)


def test_net_size_widens_for_wide_people_within_bounds() -> None:
    cfg = RoiConfig()
    narrow = cfg.net_size([with_margin(person(w=200, h=800), 0.1)])
    wide = cfg.net_size([with_margin(person(w=700, h=800), 0.1)])
    assert narrow == (128, 320), "a 200x800 box plus margins (0.375) is held at min_aspect 0.4"
    assert wide[0] > narrow[0] and wide[1] == 320
    assert cfg.net_size([with_margin(person(w=3000, h=500), 0.0)]) == (320, 320), "capped at max_aspect"


def test_people_side_by_side_share_a_crop_but_distant_ones_do_not() -> None:
    a, b = with_margin(person(400, 900), 0.1), with_margin(person(500, 900), 0.1)  # overlapping
    far = with_margin(person(60, 700, 120, 400), 0.1)
    merged = merge_regions([a, b, far], max_growth=1.3)
    assert len(merged) == 2
    assert merged[0] == (min(a[0], b[0]), a[1], max(a[2], b[2]), a[3])
    assert merged[1] == far
    assert merge_regions([a, b], max_growth=1.0) == [a, b], "no growth allowed: no merge"
    sched = RoiScheduler(RoiConfig())
    sched.report(full=True, lost_track=False)
    plan = sched.plan(SIZES[:1], [{1: person(400, 900), 2: person(500, 900), 3: person(60, 700, 120, 400)}])
    assert len(plan.jobs) == 2, "three people, two crops"


@pytest.mark.parametrize(
    ("changes", "match"),
    [({"long_side": 100}, "multiple of 32"), ({"margin": -1}, "margin"), ({"full_every": 0}, "full_every"),
     ({"min_aspect": 2.0}, "min_aspect"), ({"merge_growth": 0.5}, "merge_growth")],
)
def test_config_rejects_bad_values(changes: dict[str, float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        replace(RoiConfig(), **changes)  # type: ignore[arg-type]


def test_crops_stay_still_while_the_person_stays_inside() -> None:
    sched = RoiScheduler(RoiConfig(margin=0.1))
    sched.report(full=True, lost_track=False)
    crops = []
    for k in range(12):
        plan = sched.plan(SIZES[:1], [{1: person(400 + 10 * k, 900)}])
        sched.report(full=False, lost_track=False)
        crops.append(plan.jobs[0][1])
    assert crops[1] == crops[0], "a person 10 px further on is still inside the first crop"
    moved = [k for k in range(1, 12) if crops[k] != crops[k - 1]]
    assert moved, "the crop follows once the person (with margin) would leave it"
    for k, crop in enumerate(crops):
        assert crop is not None
        region = with_margin(person(400 + 10 * k, 900), 0.1)
        assert crop[0] <= region[0] and crop[2] >= region[2], f"frame {k}: the person is inside the crop"
    sched.report(full=True, lost_track=False)
    fresh = sched.plan(SIZES[:1], [{1: person(400, 900)}]).jobs[0][1]
    assert fresh == crops[0], "after a full pass crops are planned afresh"
