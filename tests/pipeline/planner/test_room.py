"""The room of a plan: the floor polygon the walls close, cameras inside it, walls that hide, regions."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.camera import Camera, look_at
from pipeline.cave import CaveGeometry, Wall, box_cave
from pipeline.errors import InputError
from pipeline.planner.room import (
    check_cameras,
    floor_polygon,
    inside,
    regions,
    wall_blocks,
)
from pipeline.sim.scene import PRESETS, default_cameras


def _wall(name: str, a: tuple[float, float], b: tuple[float, float], h: float = 2.5) -> Wall:
    """A vertical wall from floor point a to b (as seen from inside: a on the left)."""
    return Wall(name, np.array([[a[0], a[1], h], [b[0], b[1], h], [b[0], b[1], 0.0], [a[0], a[1], 0.0]]))


def _l_room() -> CaveGeometry:
    """An L-shaped CAVE: a 3 x 3 m square with its (+x, +y) quarter cut out."""
    pts = [(-1.5, -1.5), (1.5, -1.5), (1.5, 0.0), (0.0, 0.0), (0.0, 1.5), (-1.5, 1.5)]
    # walls run clockwise seen from above so that their inside faces the room
    walls = [_wall(f"w{i}", pts[(i + 1) % 6], pts[i]) for i in range(6)]
    return CaveGeometry(tuple(walls))


def _camera(
    name: str, eye: tuple[float, float, float], target: tuple[float, float, float] = (0, 0, 1)
) -> Camera:
    p = PRESETS["kinect_color"]
    R, t = look_at(np.array(eye, dtype=float), np.array(target, dtype=float))
    return Camera(name, p.image_size, p.K(), np.asarray(p.dist), R, t)


def test_the_default_cave_closes_into_its_floor_square() -> None:
    room = floor_polygon(box_cave(3.0, 3.0, 2.5))
    assert sorted(map(tuple, room.polygon_xy.round(6).tolist())) == sorted(
        [(1.5, 1.5), (-1.5, 1.5), (-1.5, -1.5), (1.5, -1.5)]
    )
    p, q = room.edges
    area = float((p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]).sum()) / 2
    assert area == pytest.approx(9.0), "counter-clockwise, 9 m²"
    assert room.height_m == pytest.approx(2.5)
    assert np.allclose(room.centroid_xy, 0.0)
    assert inside(room, np.array([[0.0, 0.0], [1.4, -1.4], [1.6, 0.0], [0.0, -2.0]])).tolist() == [
        True,
        True,
        False,
        False,
    ]


def test_an_l_shaped_room_closes_and_its_inner_corner_hides() -> None:
    room = floor_polygon(_l_room())
    assert len(room.polygon_xy) == 6
    assert not inside(room, np.array([0.7, 0.7])), "the cut-out quarter is not floor"
    eye = np.array([1.2, -0.3, 2.0])  # in the +x wing
    behind = np.array([[-0.3, 1.2, 1.0], [-1.0, -1.0, 1.0]])  # in the +y wing (hidden), in the base (seen)
    assert wall_blocks(room, eye, behind).tolist() == [True, False]
    assert not wall_blocks(floor_polygon(box_cave()), eye, behind).any(), "a box room hides nothing inside"


@pytest.mark.parametrize(
    ("walls", "match"),
    [
        (
            box_cave().walls[:3],
            r"do not close: wall 'front' ends at \(-1\.50, 1\.50\) m where no other wall starts",
        ),
        (
            (*box_cave().walls[:3], _wall("left", (-1.5, -1.2), (-1.5, 1.5))),
            "do not close",
        ),
        (box_cave().walls[:2], "at least three vertical walls"),
        (
            (*box_cave().walls, _wall("extra", (1.5, 1.5), (0.0, 0.0))),
            "do not close into one room",
        ),
    ],
)
def test_walls_that_do_not_close_are_one_clear_error(walls: tuple[Wall, ...], match: str) -> None:
    with pytest.raises(InputError, match=match):
        floor_polygon(CaveGeometry(tuple(walls)))


def test_a_floor_screen_is_ignored_by_the_floor_polygon() -> None:
    floor = Wall("floor", np.array([[-1.5, 1.5, 0.0], [1.5, 1.5, 0.0], [1.5, -1.5, 0.0], [-1.5, -1.5, 0.0]]))
    room = floor_polygon(CaveGeometry((*box_cave().walls, floor)))
    assert len(room.polygon_xy) == 4
    assert {w.name for w in room.walls} == {"front", "right", "back", "left"}


@pytest.mark.parametrize(
    ("cameras", "match"),
    [
        ([], "zero cameras"),
        ([_camera("a", (1.2, 1.2, 2.3))], "at least two cameras"),
        (
            [_camera("a", (1.2, 1.2, 2.3)), _camera("far", (2.5, 0.0, 2.3))],
            r"camera far at \(2\.50, 0\.00, 2\.30\) m is outside",
        ),
        (
            [_camera("a", (1.2, 1.2, 2.3)), _camera("high", (0.0, 1.0, 3.5))],
            "camera high .* is outside the room",
        ),
        ([_camera("a", (1.2, 1.2, 2.3)), _camera("under", (0.0, 1.0, -0.2))], "camera under .* is outside"),
    ],
)
def test_bad_camera_sets_are_one_clear_error(cameras: list[Camera], match: str) -> None:
    with pytest.raises(InputError, match=match):
        check_cameras(floor_polygon(box_cave()), cameras)


def test_cameras_on_the_walls_and_the_frame_are_inside() -> None:
    room = floor_polygon(box_cave())
    check_cameras(room, default_cameras(box_cave()))
    check_cameras(room, [_camera("wall", (1.5, 0.0, 2.3)), _camera("frame", (-1.5, -1.5, 2.9))])


def test_regions_group_the_benchmark_cells_as_it_does() -> None:
    c = np.array([-1.25, -0.75, -0.25, 0.25, 0.75, 1.25])
    xy = np.stack(np.meshgrid(c, c), axis=-1)
    reg = regions(floor_polygon(box_cave()), xy, 0.5)
    counts = {r: int((reg == r).sum()) for r in ("centre", "inner", "edges", "corners")}
    assert counts == {"centre": 4, "inner": 12, "edges": 16, "corners": 4}
    assert reg[0, 0] == "corners" and reg[2, 2] == "centre" and reg[0, 2] == "edges" and reg[1, 1] == "inner"
