"""Coverage maps: the simulator's visibility vectorised, the Monte Carlo through the real triangulation,
and the default CAVE's map (the corners come out worse than the centre, as the paper reports)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pipeline.cave import box_cave
from pipeline.errors import InputError
from pipeline.planner.config import PlannerConfig, SearchConfig
from pipeline.planner.coverage import coverage_map, place, see, standing_poses
from pipeline.planner.room import floor_polygon
from pipeline.sim.scene import default_cameras
from pipeline.sim.views import FaultConfig, visibility
from pipeline.skeleton import J

QUICK = PlannerConfig(grid_step_m=0.3, samples=2, heights_m=(1.75,))


@pytest.fixture(scope="module")
def default_map():
    cave = box_cave()
    return coverage_map(cave, default_cameras(cave), QUICK)


def test_visibility_is_the_simulators_own_model() -> None:
    cave = box_cave()
    cams = default_cameras(cave)
    poses = standing_poses((1.55, 1.9), (0.0, 60.0, 170.0, 255.0))
    cells = np.random.default_rng(3).uniform(-1.0, 1.0, (12, 2))  # clear of the walls: only bodies hide
    sight = see(floor_polygon(cave), cams, poses, cells, FaultConfig())
    pts = place(poses, cells)
    for c, cam in enumerate(cams):
        for g in range(len(cells)):
            for p in range(len(poses.joints_m)):
                v = visibility(cam, [pts[g, p]], 0)
                assert np.array_equal(v.in_image, sight.in_view[c, g, p]), (c, g, p)
                assert np.array_equal(v.hidden, sight.hidden[c, g, p]), (c, g, p)
    assert 0.05 < sight.hidden.mean() < 0.5, "standing people hide some of their own joints"
    facing_away = sight.hidden[:, :, :, J["nose"]]
    assert facing_away.any() and not facing_away.all()


def test_the_default_cave_is_worse_in_the_corners_than_in_the_centre(default_map) -> None:
    m = default_map
    centre, corners, edges = m.regions["centre"], m.regions["corners"], m.regions["edges"]
    assert corners.error_mm > 1.5 * centre.error_mm, (corners, centre)
    assert edges.error_mm > centre.error_mm, (edges, centre)
    assert corners.covered2 < centre.covered2 and corners.views < centre.views
    assert corners.valid < centre.valid
    assert 2.0 < centre.error_mm < 20.0, "a few millimetres at the centre with 2.5 px noise"
    assert m.worst_region == "corners"
    assert m.error_mm.shape == m.grid.shape and np.isnan(m.error_mm[~m.grid.used]).all()
    assert m.views_joint.shape == (17, *m.grid.shape)
    # the face is seen by fewer cameras than the shoulders (it is hidden from behind)
    assert np.nanmean(m.views_joint[J["nose"]]) < np.nanmean(m.views_joint[J["l_shoulder"]])


def test_the_monte_carlo_goes_through_the_triangulation() -> None:
    cave = box_cave()
    cams = default_cameras(cave)
    cfg = PlannerConfig(grid_step_m=0.5, samples=2, heights_m=(1.75,), facings_deg=(0.0, 180.0))
    exact = coverage_map(cave, cams, PlannerConfig(**{**_fields(cfg), "faults": FaultConfig.perfect()}))
    assert np.nanmax(exact.error_mm) < 0.5, "no 2D noise: the triangulation returns the truth"
    base = coverage_map(cave, cams, cfg)
    noisy = coverage_map(
        cave, cams, PlannerConfig(**{**_fields(cfg), "faults": FaultConfig(pixel_noise_px=5.0)})
    )
    ratio = noisy.floor.error_mm / base.floor.error_mm
    assert 1.5 < ratio < 2.5, f"twice the pixel noise, about twice the 3D error (got x{ratio:.2f})"


def test_the_same_seed_gives_the_same_map_and_the_numbers_are_json(default_map) -> None:
    cave = box_cave()
    again = coverage_map(cave, default_cameras(cave), QUICK)
    assert np.array_equal(again.error_mm, default_map.error_mm, equal_nan=True)
    data = json.loads(json.dumps(default_map.to_dict(), allow_nan=False))
    assert set(data["regions"]) == {"centre", "inner", "edges", "corners"}
    assert data["maps"]["error_mm"][0][0] is None, "unused cells are null"
    assert len(data["cameras"]) == 4 and data["cameras"][0]["hfov_deg"] == pytest.approx(84.3, abs=0.2)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"grid_step_m": 0.0}, "grid_step_m"),
        ({"heights_m": (0.5,)}, "heights_m"),
        ({"heights_m": ()}, "heights_m"),
        ({"samples": 0}, "samples"),
        ({"facings_deg": ("north",)}, "facings_deg"),
    ],
)
def test_bad_planner_settings_are_input_errors(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(InputError, match=match):
        PlannerConfig(**kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"count": 1}, "count must be in"),
        ({"count": 0}, "count must be in"),
        ({"mounts": ("ceiling",)}, "mounts"),
    ],
)
def test_bad_search_settings_are_input_errors(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(InputError, match=match):
        SearchConfig(**kwargs)  # type: ignore[arg-type]


def test_a_map_refuses_zero_cameras_and_cameras_outside() -> None:
    cave = box_cave()
    with pytest.raises(InputError, match="zero cameras"):
        coverage_map(cave, [], QUICK)
    outside = default_cameras(box_cave(5.0, 5.0, 2.5))
    with pytest.raises(InputError, match="outside the room"):
        coverage_map(cave, outside, QUICK)


def _fields(obj: object) -> dict[str, object]:
    return {name: getattr(obj, name) for name in obj.__dataclass_fields__}  # type: ignore[attr-defined]


def test_camera_order_does_not_change_who_sees_what(default_map) -> None:
    cave = box_cave()
    flipped = coverage_map(cave, default_cameras(cave)[::-1], QUICK)
    assert np.array_equal(flipped.views, default_map.views, equal_nan=True)
    assert np.array_equal(flipped.covered2, default_map.covered2, equal_nan=True)


def test_an_l_shaped_room_is_mapped_and_its_walls_hide() -> None:
    from tests.pipeline.planner.test_room import _camera, _l_room

    cave = _l_room()
    cams = [_camera("a", (-1.35, -1.35, 2.3)), _camera("b", (1.35, -1.35, 2.3), (0.5, -0.75, 1.0)),
            _camera("c", (-1.35, 1.35, 2.3), (0.3, -0.3, 1.0))]  # fmt: skip
    m = coverage_map(cave, cams, QUICK)
    xx, yy = np.meshgrid(m.grid.x_m, m.grid.y_m)
    assert not m.grid.used[(xx > 0.1) & (yy > 0.1)].any(), "no cell in the cut-out quarter"
    assert np.isfinite(m.error_mm[m.grid.used]).mean() > 0.5
    # the +x wing: camera c looks at it across the inner corner, whose walls hide it
    box = coverage_map(box_cave(), cams, QUICK)
    wing = m.grid.used & (xx > 0.6) & (yy < -0.3)
    assert wing.any() and np.nanmean(m.views[wing]) < np.nanmean(box.views[wing]) - 0.3
