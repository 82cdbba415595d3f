"""ArUco marker patterns shown on the CAVE walls, and their layout in the CAVE frame.

Pixel convention shared with the simulator: a wall's pattern image covers the whole
wall, and the continuous image position (u, v) — u = 0 at the left *edge* of the
image, u = W at its right edge, pixel ``i`` spanning [i, i + 1) — lies at
``wall.point_at(u / W, v / H)``. (OpenCV pixel-centre coordinates are these minus 0.5.)

Marker corners are in OpenCV's ArUco order: top-left, top-right, bottom-right,
bottom-left of the marker image as displayed, i.e. the outer corners of its black border.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from pipeline.calibration.config import DICTIONARY_SIZES, CalibrationConfig
from pipeline.cave import CaveGeometry, Wall
from pipeline.errors import InputError

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]
U8 = NDArray[np.uint8]


@dataclass(frozen=True, slots=True, eq=False)
class Marker:
    """One ArUco marker on a wall.

    id: the marker's id in the layout's dictionary.
    wall: the name of the wall it is shown on.
    corners_m: (4, 3) outer corners in the CAVE frame, metres, ArUco order (TL, TR, BR, BL).
    """

    id: int
    wall: str
    corners_m: F64

    def __post_init__(self) -> None:
        if isinstance(self.id, bool) or not isinstance(self.id, int | np.integer) or self.id < 0:
            raise InputError(f"marker id must be a non-negative integer, got {self.id!r}")
        object.__setattr__(self, "id", int(self.id))
        if not isinstance(self.wall, str) or not self.wall:
            raise InputError(f"marker {self.id}: wall must be a non-empty name, got {self.wall!r}")
        try:
            c = np.asarray(self.corners_m, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(f"marker {self.id}: corners must be numbers") from exc
        if c.shape != (4, 3):
            raise InputError(f"marker {self.id}: expected 4 corners of [x, y, z], got shape {c.shape}")
        if not np.all(np.isfinite(c)):
            raise InputError(f"marker {self.id}: corners contain NaN or infinite values")
        if np.linalg.norm(c[1] - c[0]) < 1e-4 or np.linalg.norm(c[3] - c[0]) < 1e-4:
            raise InputError(f"marker {self.id}: corners are degenerate")
        object.__setattr__(self, "corners_m", c)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Marker):
            return NotImplemented
        return (
            self.id == other.id
            and self.wall == other.wall
            and np.allclose(self.corners_m, other.corners_m, rtol=0, atol=1e-12)
        )

    def __hash__(self) -> int:
        return hash((self.id, self.wall))


@dataclass(frozen=True, slots=True)
class MarkerLayout:
    """Every marker shown on the walls: the dictionary and the markers (ids distinct)."""

    dictionary: str
    markers: tuple[Marker, ...]
    _by_id: dict[int, Marker] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.dictionary not in DICTIONARY_SIZES:
            raise InputError(
                f"unknown ArUco dictionary {self.dictionary!r}; expected one of {', '.join(DICTIONARY_SIZES)}"
            )
        markers = tuple(self.markers)
        if not markers:
            raise InputError("a marker layout needs at least one marker")
        size = DICTIONARY_SIZES[self.dictionary]
        by_id: dict[int, Marker] = {}
        for m in markers:
            if not isinstance(m, Marker):
                raise InputError(f"layout markers must be Marker objects, got {type(m).__name__}")
            if m.id >= size:
                raise InputError(f"marker id {m.id} is out of range for {self.dictionary} (0..{size - 1})")
            if m.id in by_id:
                raise InputError(f"marker id {m.id} appears more than once in the layout")
            by_id[m.id] = m
        object.__setattr__(self, "markers", markers)
        object.__setattr__(self, "_by_id", by_id)

    def marker(self, marker_id: int) -> Marker | None:
        """The marker with this id, or None if the layout has none."""
        return self._by_id.get(int(marker_id))

    @property
    def walls(self) -> tuple[str, ...]:
        """Names of the walls that show markers, in first-appearance order."""
        return tuple(dict.fromkeys(m.wall for m in self.markers))

    def on_wall(self, wall: str) -> tuple[Marker, ...]:
        return tuple(m for m in self.markers if m.wall == wall)


def aruco_dictionary(name: str) -> cv2.aruco.Dictionary:
    """OpenCV's predefined ArUco dictionary of this name."""
    if name not in DICTIONARY_SIZES:
        raise InputError(f"unknown ArUco dictionary {name!r}; expected one of {', '.join(DICTIONARY_SIZES)}")
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))


def wall_to_pixels(wall: Wall, points_m: F64) -> F64:
    """(N, 3) points on the wall -> (N, 2) continuous pattern-image coordinates (pixel-edge convention)."""
    pts = np.asarray(points_m, dtype=np.float64).reshape(-1, 3)
    c = wall.corners_m
    eu, ev = c[1] - c[0], c[3] - c[0]
    d = pts - c[0]
    w, h = wall.resolution_px
    u = d @ eu / float(eu @ eu) * w
    v = d @ ev / float(ev @ ev) * h
    return np.stack([u, v], axis=1)


def pixels_to_wall(wall: Wall, uv_px: F64) -> F64:
    """(N, 2) continuous pattern-image coordinates -> (N, 3) points in the CAVE frame."""
    uv = np.asarray(uv_px, dtype=np.float64).reshape(-1, 2)
    w, h = wall.resolution_px
    pts: F64 = wall.point_at(uv[:, 0] / w, uv[:, 1] / h)
    return pts


def make_layout(cave: CaveGeometry, config: CalibrationConfig | None = None) -> MarkerLayout:
    """A grid of ArUco markers on every wall, ids distinct across walls, sized to each wall.

    Each wall gets ``config.grid`` markers centred inside a white margin; markers are
    whole numbers of pixels per module (crisp on the display) with a white quiet zone
    of at least one module between neighbours. Wall k uses ids k*n .. k*n + n - 1.
    """
    cfg = config or CalibrationConfig()
    cols, rows = cfg.grid
    per_wall = cfg.markers_per_wall
    size = DICTIONARY_SIZES[cfg.dictionary]
    if per_wall * len(cave.walls) > size:
        raise InputError(
            f"{len(cave.walls)} walls x {per_wall} markers need {per_wall * len(cave.walls)} ids, "
            f"but {cfg.dictionary} has only {size}; use a smaller grid or a larger dictionary"
        )
    modules = aruco_dictionary(cfg.dictionary).markerSize + 2  # data bits + one-bit black border
    markers: list[Marker] = []
    for k, wall in enumerate(cave.walls):
        w, h = wall.resolution_px
        margin = cfg.margin_frac * min(w, h)
        cell = min((w - 2 * margin) / cols, (h - 2 * margin) / rows)
        module_px = int(cell * (1.0 - cfg.quiet_frac) // modules)
        if module_px < 2:
            raise InputError(
                f"wall {wall.name}: {w}x{h} px is too small for a {cols}x{rows} marker grid "
                f"(markers would have {module_px} px per module, need at least 2)"
            )
        side = module_px * modules
        x_start = (w - cols * cell) / 2.0
        y_start = (h - rows * cell) / 2.0
        for r in range(rows):
            for c in range(cols):
                x0 = round(x_start + c * cell + (cell - side) / 2.0)
                y0 = round(y_start + r * cell + (cell - side) / 2.0)
                uv = np.array(
                    [[x0, y0], [x0 + side, y0], [x0 + side, y0 + side], [x0, y0 + side]], dtype=np.float64
                )
                markers.append(Marker(k * per_wall + r * cols + c, wall.name, pixels_to_wall(wall, uv)))
    log.debug("layout: %d markers on %d walls", len(markers), len(cave.walls))
    return MarkerLayout(cfg.dictionary, tuple(markers))


def render_wall_pattern(cave: CaveGeometry, layout: MarkerLayout, wall_name: str) -> U8:
    """The (H, W) uint8 image the wall's workstation shows: white, with the wall's markers."""
    wall = cave.wall(wall_name)
    markers = layout.on_wall(wall_name)
    if not markers:
        raise InputError(
            f"the layout has no markers on wall {wall_name!r} (walls: {', '.join(layout.walls)})"
        )
    dictionary = aruco_dictionary(layout.dictionary)
    w, h = wall.resolution_px
    img = np.full((h, w), 255, dtype=np.uint8)
    for m in markers:
        uv = wall_to_pixels(wall, m.corners_m)
        if np.any(uv < -0.5) or np.any(uv[:, 0] > w + 0.5) or np.any(uv[:, 1] > h + 0.5):
            raise InputError(f"marker {m.id} lies outside wall {wall_name!r}")
        side_f = float(np.linalg.norm(uv[1] - uv[0]))
        side = max(round(side_f), dictionary.markerSize + 2)
        tile = cv2.aruco.generateImageMarker(dictionary, m.id, side, borderBits=1)
        expected = np.array([[0, 0], [side, 0], [side, side], [0, side]], dtype=np.float64) + np.round(uv[0])
        if np.allclose(uv, expected, atol=1e-6):
            x0, y0 = round(float(uv[0, 0])), round(float(uv[0, 1]))
            img[y0 : y0 + side, x0 : x0 + side] = tile
            continue
        # A marker that is not pixel-aligned (a layout from elsewhere): warp it into place.
        src = np.array([[0, 0], [side, 0], [side, side], [0, side]], dtype=np.float32) - 0.5
        homography = cv2.getPerspectiveTransform(src, (uv - 0.5).astype(np.float32))
        warped = cv2.warpPerspective(tile, homography, (w, h), flags=cv2.INTER_LINEAR, borderValue=255)
        mask = cv2.warpPerspective(np.ones_like(tile), homography, (w, h), flags=cv2.INTER_NEAREST)
        img[mask > 0] = warped[mask > 0]
    return img


def layout_to_dict(layout: MarkerLayout) -> dict[str, Any]:
    """The marker layout JSON object of SPEC.md."""
    return {
        "dictionary": layout.dictionary,
        "markers": [{"id": m.id, "wall": m.wall, "corners": m.corners_m.tolist()} for m in layout.markers],
    }


def layout_from_dict(data: object) -> MarkerLayout:
    """Parse the marker layout JSON object; raises InputError naming what is malformed."""
    if not isinstance(data, dict):
        raise InputError("marker layout must be a JSON object with 'dictionary' and 'markers'")
    missing = [k for k in ("dictionary", "markers") if k not in data]
    if missing:
        raise InputError(f"marker layout is missing {', '.join(repr(k) for k in missing)}")
    if not isinstance(data["dictionary"], str):
        raise InputError("marker layout 'dictionary' must be a name such as 'DICT_4X4_250'")
    items = data["markers"]
    if not isinstance(items, list):
        raise InputError("marker layout 'markers' must be a list")
    markers = []
    for i, item in enumerate(items):
        if not isinstance(item, dict):
            raise InputError(f"marker #{i} must be an object with 'id', 'wall' and 'corners'")
        absent = [k for k in ("id", "wall", "corners") if k not in item]
        if absent:
            raise InputError(f"marker #{i} is missing {', '.join(repr(k) for k in absent)}")
        if isinstance(item["id"], bool) or not isinstance(item["id"], int):
            raise InputError(f"marker #{i}: 'id' must be an integer, got {item['id']!r}")
        markers.append(Marker(item["id"], item["wall"], item["corners"]))
    return MarkerLayout(data["dictionary"], tuple(markers))


def save_layout(path: Path | str, layout: MarkerLayout) -> None:
    """Write the marker layout JSON of SPEC.md."""
    Path(path).write_text(json.dumps(layout_to_dict(layout), indent=1) + "\n", encoding="utf-8")


def load_layout(path: Path | str) -> MarkerLayout:
    """Read a marker layout JSON; raises InputError for a missing or malformed file."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"marker layout not found: {p}")
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"marker layout {p} is not valid JSON: {exc}") from exc
    try:
        return layout_from_dict(data)
    except InputError as exc:
        raise InputError(f"malformed marker layout {p}: {exc}") from exc
