"""CAVE geometry: wall corner order, normals, validation."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.cave import Wall, box_cave
from pipeline.errors import InputError


def test_wall_normals_point_into_the_cave() -> None:
    for wall in box_cave().walls:
        centre = wall.corners_m.mean(axis=0)
        to_origin = np.array([0.0, 0.0, centre[2]]) - centre
        assert wall.normal @ to_origin > 0, f"{wall.name} normal {wall.normal} points outwards"


def test_point_at_maps_image_corners_to_wall_corners() -> None:
    front = box_cave(3.0, 3.0, 2.5).wall("front")
    assert np.allclose(front.point_at(0.0, 0.0), [-1.5, 1.5, 2.5])
    assert np.allclose(front.point_at(1.0, 1.0), [1.5, 1.5, 0.0])
    assert front.width_m == pytest.approx(3.0) and front.height_m == pytest.approx(2.5)


@pytest.mark.parametrize(
    ("corners", "match"),
    [
        ([[0, 0, 0]] * 4, "degenerate"),
        ([[0, 0, 1], [1, 0, 1], [1, 0.5, 0], [0, 0, 0]], "coplanar|rectangle"),
        ([[0, 0, 1], [1, 0, 1], [2, 0, 0], [0, 0, 0]], "rectangle"),
        ([[0, 0, 1], [1, 0, 1], [1, 0, 0]], "4 finite"),
    ],
)
def test_bad_walls_are_rejected(corners: list[list[float]], match: str) -> None:
    with pytest.raises(InputError, match=match):
        Wall("w", np.array(corners, dtype=float))


def test_unknown_wall_name() -> None:
    with pytest.raises(InputError, match="unknown wall 'ceiling'"):
        box_cave().wall("ceiling")
