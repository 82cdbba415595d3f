"""Wall patterns and the marker layout: real renders decoded by OpenCV's ArUco detector."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.calibration.config import CalibrationConfig
from pipeline.calibration.patterns import (
    Marker,
    MarkerLayout,
    aruco_dictionary,
    load_layout,
    make_layout,
    render_wall_pattern,
    save_layout,
    wall_to_pixels,
)
from pipeline.cave import box_cave
from pipeline.errors import InputError


def _detect(img: np.ndarray, dictionary: str) -> tuple[list[np.ndarray], np.ndarray]:
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    detector = cv2.aruco.ArucoDetector(aruco_dictionary(dictionary), params)
    corners, ids, _ = detector.detectMarkers(img)
    return [c.reshape(4, 2) for c in corners], (np.empty(0, int) if ids is None else ids.ravel())


def test_layout_has_distinct_ids_on_every_wall_within_the_wall() -> None:
    cave = box_cave()
    layout = make_layout(cave)
    ids = [m.id for m in layout.markers]
    assert len(ids) == len(set(ids)) == 4 * 30
    assert layout.walls == ("front", "right", "back", "left")
    for wall in cave.walls:
        for m in layout.on_wall(wall.name):
            uv = wall_to_pixels(wall, m.corners_m)
            w, h = wall.resolution_px
            assert np.all(uv >= 0) and np.all(uv[:, 0] <= w) and np.all(uv[:, 1] <= h), m.id
            # corners lie on the wall's plane
            dist = (m.corners_m - wall.corners_m[0]) @ wall.normal
            assert np.allclose(dist, 0, atol=1e-9), f"marker {m.id} is off its wall"


@pytest.mark.parametrize("wall_name", ["front", "right", "back", "left"])
def test_rendered_markers_decode_with_their_ids_at_their_corners(wall_name: str) -> None:
    cave = box_cave()
    layout = make_layout(cave)
    img = render_wall_pattern(cave, layout, wall_name)
    wall = cave.wall(wall_name)
    assert img.shape == (wall.resolution_px[1], wall.resolution_px[0]) and img.dtype == np.uint8
    corners, ids = _detect(cv2.GaussianBlur(img, (0, 0), 0.8), layout.dictionary)
    assert sorted(ids.tolist()) == sorted(m.id for m in layout.on_wall(wall_name))
    for c, marker_id in zip(corners, ids, strict=True):
        marker = layout.marker(int(marker_id))
        assert marker is not None
        # OpenCV pixel centres = pattern (edge) coordinates - 0.5; ArUco order TL, TR, BR, BL.
        expected = wall_to_pixels(wall, marker.corners_m) - 0.5
        assert np.abs(c - expected).max() < 0.3, f"marker {marker_id}: {c} vs {expected}"


def test_unaligned_layout_from_elsewhere_still_renders_decodable_markers() -> None:
    cave = box_cave()
    wall = cave.wall("front")
    # A single tilted marker, as another tool could write it.
    centre, half, ang = np.array([960.0, 800.0]), 150.0, np.deg2rad(10)
    rot = np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
    uv = centre + np.array([[-half, -half], [half, -half], [half, half], [-half, half]]) @ rot.T
    corners_m = wall.point_at(uv[:, 0] / 1920, uv[:, 1] / 1600)
    layout = MarkerLayout("DICT_4X4_250", (Marker(7, "front", corners_m),))
    corners, ids = _detect(render_wall_pattern(cave, layout, "front"), "DICT_4X4_250")
    assert ids.tolist() == [7]
    assert np.abs(corners[0] - (uv - 0.5)).max() < 1.0


def test_render_rejects_unknown_wall_and_wall_without_markers() -> None:
    cave = box_cave()
    layout = make_layout(cave)
    with pytest.raises(InputError, match="unknown wall 'ceiling'"):
        render_wall_pattern(cave, layout, "ceiling")
    only_front = MarkerLayout(layout.dictionary, layout.on_wall("front"))
    with pytest.raises(InputError, match="no markers on wall 'back'"):
        render_wall_pattern(cave, only_front, "back")


def test_grid_too_large_for_dictionary_or_wall_is_refused() -> None:
    with pytest.raises(InputError, match="has only 50"):
        make_layout(box_cave(), CalibrationConfig(dictionary="DICT_4X4_50"))
    with pytest.raises(InputError, match="too small"):
        make_layout(box_cave(resolution_px=(64, 48)), CalibrationConfig(grid=(6, 5)))


def test_the_stage_config_defaults() -> None:
    cfg = CalibrationConfig()
    assert cfg.dictionary == "DICT_4X4_250" and cfg.grid == (6, 5)


_coord = st.floats(-5, 5, allow_nan=False, allow_infinity=False)


@st.composite
def _layouts(draw: st.DrawFn) -> MarkerLayout:
    n = draw(st.integers(1, 8))
    ids = draw(st.lists(st.integers(0, 249), min_size=n, max_size=n, unique=True))
    markers = []
    for marker_id in ids:
        origin = np.array([draw(_coord) for _ in range(3)])
        side = draw(st.floats(0.01, 1.0))
        corners = origin + side * np.array([[0, 0, 1], [1, 0, 1], [1, 0, 0], [0, 0, 0]], dtype=float)
        markers.append(Marker(marker_id, draw(st.sampled_from(["front", "left", "w-3"])), corners))
    return MarkerLayout("DICT_4X4_250", tuple(markers))


@settings(max_examples=30, deadline=None)
@given(layout=_layouts())
def test_layout_saved_and_loaded_is_the_same(
    tmp_path_factory: pytest.TempPathFactory, layout: MarkerLayout
) -> None:
    path = tmp_path_factory.mktemp("layout") / "layout.json"
    save_layout(path, layout)
    assert load_layout(path) == layout


def _write(tmp_path: Path, content: object) -> Path:
    p = tmp_path / "layout.json"
    p.write_text(content if isinstance(content, str) else json.dumps(content))
    return p


_SQUARE = [[0, 0, 1], [1, 0, 1], [1, 0, 0], [0, 0, 0]]
_D = "DICT_4X4_250"


@pytest.mark.parametrize(
    ("content", "match"),
    [
        ("{not json", "not valid JSON"),
        ([1, 2], "must be a JSON object"),
        ({"markers": []}, "missing 'dictionary'"),
        ({"dictionary": "DICT_9", "markers": [{"id": 1, "wall": "a", "corners": _SQUARE}]}, "unknown ArUco"),
        ({"dictionary": _D, "markers": []}, "at least one marker"),
        ({"dictionary": _D, "markers": [{"id": 1, "wall": "a"}]}, "missing 'corners'"),
        ({"dictionary": _D, "markers": [{"id": 1, "wall": "a", "corners": [[0, 0, 0]]}]}, "4 corners"),
        ({"dictionary": _D, "markers": [{"id": "x", "wall": "a", "corners": _SQUARE}]}, "integer"),
        ({"dictionary": _D, "markers": [{"id": 300, "wall": "a", "corners": _SQUARE}]}, "out of range"),
        (
            {"dictionary": _D, "markers": [{"id": 2, "wall": "a", "corners": _SQUARE}] * 2},
            "more than once",
        ),
    ],
)
def test_malformed_layout_is_refused_by_name(tmp_path: Path, content: object, match: str) -> None:
    with pytest.raises(InputError, match=match):
        load_layout(_write(tmp_path, content))


def test_missing_layout_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not found"):
        load_layout(tmp_path / "nope.json")


def test_overlay_caption_is_readable_on_a_white_wall() -> None:
    """Issue 19.9: the caption is white text on a dark band, not white on white."""
    from pipeline.calibration.overlay import draw_caption

    img = np.full((400, 900, 3), 255, np.uint8)
    draw_caption(img, "cam01  RMS 0.31 px  42 markers  [good]", 1)
    band = img[6:40, 6:300]
    dark = (band.max(axis=2) < 90).mean()
    white = (band.min(axis=2) > 200).mean()
    assert dark > 0.6, f"the band behind the text is dark ({dark:.2f} of its pixels)"
    assert 0.03 < white < 0.4, f"the text on it is white ({white:.2f} of its pixels)"
    assert (img[200:, :] == 255).all(), "the rest of the image is untouched"
