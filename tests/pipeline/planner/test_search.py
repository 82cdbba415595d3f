"""The mount search: it must beat the default layout at the corners; its screening agrees with the
Monte Carlo; bad requests are clear errors."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.cave import box_cave
from pipeline.errors import InputError
from pipeline.planner.config import PlannerConfig, SearchConfig
from pipeline.planner.room import floor_polygon, inside
from pipeline.planner.search import candidate_mounts, first_order_error_mm, screen, search_mounts
from pipeline.sim.scene import default_cameras

PLANNER = PlannerConfig(grid_step_m=0.3, samples=2, heights_m=(1.75,))
SEARCH = SearchConfig(
    count=4, heights_m=(2.0, 2.45), pans_deg=(-25.0, 0.0, 25.0), aim_heights_m=(1.0,), top_k=2
)


def test_the_search_beats_the_default_layout_at_the_corners() -> None:
    cave = box_cave()
    result = search_mounts(cave, SEARCH, PLANNER, default_cameras=default_cameras(cave))
    assert result.default is not None and len(result.layouts) == 2
    best, default = result.layouts[0], result.default
    b, d = best.map.regions["corners"], default.map.regions["corners"]
    assert b.error_mm < d.error_mm, f"corners: best {b.error_mm:.1f} mm vs default {d.error_mm:.1f} mm"
    assert b.valid > d.valid and b.covered2 > d.covered2
    assert best.objective_mm < default.objective_mm
    assert result.layouts[0].objective_mm <= result.layouts[1].objective_mm, "best first"
    room = floor_polygon(cave)
    for layout in result.layouts:
        assert len(layout.cameras) == 4 and len({m.spot for m in layout.mounts or ()}) == 4, "distinct spots"
        assert inside(room, np.array([c.center_m[:2] for c in layout.cameras])).all()
    spot_sets = [tuple(sorted(m.spot for m in layout.mounts or ())) for layout in result.layouts]
    assert len(set(spot_sets)) == len(spot_sets), "the layouts shown are alternatives, not near-copies"
    assert result.evaluated > 50 and result.candidates == 8 * 2 * 3


def test_the_screening_ranks_regions_like_the_monte_carlo() -> None:
    cave = box_cave()
    room = floor_polygon(cave)
    cams = default_cameras(cave)
    scr = screen(room, cams, PLANNER, 0.3)
    err = first_order_error_mm(scr.info.sum(axis=0), scr.seen.sum(axis=0), 1e6)  # (G, P, J)
    seen2 = scr.seen.sum(axis=0) >= 2
    per_region = {
        r: float(np.mean(err[scr.region == r][seen2[scr.region == r]])) for r in ("centre", "corners")
    }
    assert per_region["corners"] > per_region["centre"]
    from pipeline.planner.coverage import coverage_map

    mc = coverage_map(room, cams, PLANNER)
    ratio = per_region["centre"] / mc.regions["centre"].error_mm
    assert 0.5 < ratio < 2.0, (
        f"first-order centre error {per_region['centre']:.1f} mm vs Monte Carlo x{ratio:.2f}"
    )


def test_candidates_hang_inside_at_the_corners_and_wall_middles() -> None:
    room = floor_polygon(box_cave())
    mounts = candidate_mounts(room, SEARCH, above_walls_m=0.5)
    spots = {(m.kind, round(float(m.position_m[0]), 2), round(float(m.position_m[1]), 2)) for m in mounts}
    assert ("corner", 1.35, 1.35) in spots and ("wall", 0.0, 1.35) in spots and len(spots) == 8
    assert {round(float(m.position_m[2]), 2) for m in mounts} == {2.0, 2.45}


@pytest.mark.parametrize(
    ("search", "match"),
    [
        (SearchConfig(count=9), "9 cameras need 9 mount spots; this room has 8"),
        (SearchConfig(count=3, mounts=("corner",), preset="gopro"), "unknown camera preset"),
    ],
)
def test_impossible_searches_are_one_clear_error(search: SearchConfig, match: str) -> None:
    with pytest.raises(InputError, match=match):
        search_mounts(box_cave(), search, PLANNER)
