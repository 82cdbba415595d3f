"""The ROI scheduler: when it crops, where, at what network size, and when a view is looked at whole."""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest

from pipeline.pose.config import PoseConfig
from pipeline.pose.roi import RoiScheduler, crop_region, merge_regions, roi_net_size, with_margin
from pipeline.pose.types import Job

SIZES = [(1080, 1920), (1080, 1920)]


def person(cx: float = 540, cy: float = 900, w: float = 300, h: float = 800) -> np.ndarray:
    return np.array([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2])


def started(config: PoseConfig | None = None, views: int = 2) -> RoiScheduler:
    """A scheduler past its first frame (every view looked at whole once)."""
    sched = RoiScheduler(config or PoseConfig())
    plan = sched.plan(SIZES[:1] * views, [{}] * views)
    assert plan.full and plan.reason in ("first frame", "roi off")
    sched.report()
    return sched


def test_first_frame_is_full_then_crops_per_track() -> None:
    sched = RoiScheduler(PoseConfig())
    plan = sched.plan(SIZES, [{}, {}])
    assert plan.full and plan.reason == "first frame" and plan.full_views == {0, 1}
    assert plan.jobs == (Job(0), Job(1))
    sched.report()
    plan = sched.plan(SIZES, [{1: person(), 2: person(200, 900, 150, 500)}, {1: person()}])
    assert not plan.full and plan.reason == "roi" and not plan.full_views
    assert [j.image for j in plan.jobs] == [0, 0, 1], "one crop per tracked person, all views in one plan"
    for job in plan.jobs:
        assert job.region is not None and job.net_size is not None
        x1, y1, x2, y2 = job.region
        assert (x2 - x1) / (y2 - y1) == pytest.approx(job.net_size[0] / job.net_size[1]), "no padding waste"
    big, small = plan.jobs[0].net_size, plan.jobs[1].net_size
    assert big is not None and small is not None
    assert big[1] == 320 and small[1] < big[1], "a smaller person gets a smaller network input"


def test_crops_are_sampled_no_finer_than_the_full_frame_pass() -> None:
    cfg = PoseConfig()
    full_scale = cfg.input_long_side / 1920
    for h in (300, 600, 900, 1500):
        region = with_margin(person(h=h, w=h / 3), cfg.roi_margin)
        net_w, net_h = roi_net_size(cfg, region, (1080, 1920))
        crop = crop_region(region, (1080, 1920), (net_w, net_h))
        crop_h = crop[3] - crop[1]
        assert cfg.crop_min_side <= net_h <= cfg.roi_long_side and net_h % 32 == 0 and net_w % 32 == 0
        # the smallest multiple of 32 that samples at least as finely as the full pass (or a bound)
        assert net_h - 32 < crop_h * full_scale or net_h == cfg.crop_min_side, f"h={h}: {net_h} px, {crop_h}"
        assert net_h >= min(crop_h * full_scale, cfg.roi_long_side) - 1e-6, f"h={h}: coarser than the full"


def test_a_view_without_tracks_is_looked_at_whole_at_the_crop_size() -> None:
    sched = started()
    plan = sched.plan(SIZES, [{1: person()}, {}])
    assert not plan.full and plan.jobs[1] == Job(1, None, (192, 320))


def test_a_lost_track_gets_that_view_looked_at_whole_and_only_that_view() -> None:
    sched = started()
    sched.plan(SIZES, [{1: person()}, {1: person()}])
    sched.report(lost=[1])
    plan = sched.plan(SIZES, [{1: person()}, {1: person()}])
    assert plan.reason == "track lost" and not plan.full_views
    assert [j.image for j in plan.jobs] == [0, 1, 1], "view 0 keeps its crop; view 1 a look and its crop"
    assert Job(1, None, (192, 320)) in plan.jobs, "the look is the whole view at the crop size"
    sched.report()
    assert sched.plan(SIZES, [{1: person()}, {1: person()}]).reason == "roi", "found again: crops only"


def test_looks_for_newcomers_are_staggered_over_the_views() -> None:
    views = 4
    sched = started(PoseConfig(roi_full_every=8), views)
    looked: dict[int, list[int]] = {}
    for frame in range(1, 25):
        plan = sched.plan(SIZES[:1] * views, [{1: person()}] * views)
        sched.report()
        coarse = [j.image for j in plan.jobs if j.region is None]
        assert len(coarse) <= 1, f"frame {frame}: at most one view looked at whole, got {coarse}"
        assert not plan.full_views, "a look for newcomers is not a full-frame pass"
        for view in coarse:
            looked.setdefault(view, []).append(frame)
            assert plan.reason == "look for newcomers"
            assert [j.image for j in plan.jobs].count(view) == 2, "the view keeps its crop beside the look"
    assert sorted(looked) == [0, 1, 2, 3], "every view is looked at"
    for view, frames in looked.items():
        assert all(b - a == 8 for a, b in itertools.pairwise(frames)), f"view {view}: {frames}"
    firsts = sorted(frames[0] for frames in looked.values())
    assert len(set(firsts)) == 4, f"the views' looks fall on different frames: {firsts}"


@pytest.mark.parametrize(
    ("config", "expected", "reason"),
    [
        (PoseConfig(roi=False), [{1: person()}, {1: person()}], "roi off"),
        (PoseConfig(), [{}, {}], "nobody tracked"),
        (PoseConfig(roi_max_crops=1), [{1: person()}, {1: person()}], "too many crops"),
    ],
)
def test_falls_back_to_full_frames(config: PoseConfig, expected: list[dict[int, np.ndarray]],
                                   reason: str) -> None:
    sched = started(config)
    plan = sched.plan(SIZES, expected)
    assert plan.full and plan.reason == reason and plan.full_views == {0, 1}


def test_camera_keys_keep_their_state_when_a_camera_is_missing() -> None:
    sched = RoiScheduler(PoseConfig())
    sched.plan(SIZES, [{}, {}], ["a", "b"])
    sched.report()
    sched.plan(SIZES, [{1: person()}, {1: person()}], ["a", "b"])
    sched.report(lost=["b"])
    plan = sched.plan(SIZES[:1], [{1: person()}], ["b"])  # camera a is late this frame
    assert plan.reason == "track lost" and Job(0, None, (192, 320)) in plan.jobs
    sched.report()
    plan = sched.plan(SIZES[:1], [{1: person()}], ["c"])
    assert plan.reason == "first frame", "a camera never seen starts with a full pass"


def test_report_needs_a_plan() -> None:
    with pytest.raises(RuntimeError, match="plan"):
        RoiScheduler(PoseConfig()).report()


def test_crop_region_contains_the_box_with_margin_and_stays_in_the_image() -> None:
    b = person(100, 500, 200, 600)  # near the left edge
    region = with_margin(b, 0.1)
    assert region == pytest.approx((-60, 140, 260, 860))
    net = roi_net_size(PoseConfig(), region, (1080, 1920))
    x1, y1, x2, y2 = crop_region(region, (1080, 1920), net)
    assert x1 >= 0 and y1 >= 0 and x2 <= 1080 and y2 <= 1920, "shifted into the image"
    assert x1 <= b[0] and y1 <= b[1] - 60 + 1e-6 and x2 >= b[2] and y2 >= b[3] + 60 - 1e-6
    huge = crop_region(with_margin(person(540, 960, 1080, 1920), 0.1), (1080, 1920), net)
    assert (huge[0] + huge[2]) / 2 == pytest.approx(540) and (huge[1] + huge[3]) / 2 == pytest.approx(960)


def test_net_size_widens_for_wide_people_within_bounds() -> None:
    cfg = PoseConfig()
    narrow = roi_net_size(cfg, with_margin(person(w=200, h=900), 0.1), (1080, 1920))
    wide = roi_net_size(cfg, with_margin(person(w=700, h=900), 0.1), (1080, 1920))
    assert narrow == (128, 320), "a 200x900 box plus margins (0.35) is held at min_aspect 0.4"
    assert wide[0] > narrow[0] and wide[1] == 320
    wider = roi_net_size(cfg, with_margin(person(w=3000, h=1000), 0.0), (1080, 1920))
    assert wider == (320, 320), "max_aspect"


def test_people_side_by_side_share_a_crop_but_distant_ones_do_not() -> None:
    a, b = with_margin(person(400, 900), 0.1), with_margin(person(420, 900), 0.1)  # nearly on top
    far = with_margin(person(60, 700, 120, 400), 0.1)
    merged = merge_regions([a, b, far], max_growth=1.1)
    assert len(merged) == 2
    assert merged[0] == (min(a[0], b[0]), a[1], max(a[2], b[2]), a[3])
    assert merged[1] == far
    assert merge_regions([a, b], max_growth=1.0) == [a, b], "no growth allowed: no merge"
    sched = started(views=1)
    plan = sched.plan(SIZES[:1], [{1: person(400, 900), 2: person(420, 900), 3: person(60, 700, 120, 400)}])
    assert len(plan.jobs) == 2, "three people, two crops"


@pytest.mark.parametrize(
    ("changes", "match"),
    [({"roi_long_side": 100}, "multiple of 32"), ({"roi_min_side": 40}, "multiple of 32"),
     ({"roi_min_side": 352}, "min_side"), ({"roi_margin": -1}, "margin"),
     ({"roi_full_every": 0}, "full_every"),
     ({"roi_min_aspect": 2.0}, "min_aspect"), ({"roi_merge_growth": 0.5}, "merge_growth")],
)
def test_config_rejects_bad_values(changes: dict[str, float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        replace(PoseConfig(), **changes)  # type: ignore[arg-type]


def test_crops_stay_still_while_the_person_stays_inside() -> None:
    sched = started(PoseConfig(roi_margin=0.1), views=1)
    crops = []
    for k in range(12):
        plan = sched.plan(SIZES[:1], [{1: person(400 + 10 * k, 900)}])
        sched.report()
        crops.append(plan.jobs[0].region)
    assert crops[1] == crops[0], "a person 10 px further on is still inside the first crop"
    moved = [k for k in range(1, 12) if crops[k] != crops[k - 1]]
    assert moved, "the crop follows once the person (with margin) would leave it"
    for k, crop in enumerate(crops):
        assert crop is not None
        region = with_margin(person(400 + 10 * k, 900), 0.1)
        assert crop[0] <= region[0] and crop[2] >= region[2], f"frame {k}: the person is inside the crop"
    sched.plan(SIZES[:1], [{}])
    sched.report()  # nobody tracked: a full pass
    fresh = sched.plan(SIZES[:1], [{1: person(400, 900)}]).jobs[0].region
    assert fresh == crops[0], "after a full pass crops are planned afresh"
