"""The room a plan is made for: the floor polygon the walls enclose, what is inside it, what a wall hides.

Pure geometry on :class:`pipeline.cave.CaveGeometry`:

- :func:`floor_polygon`: the walls' bottom edges chained into one closed polygon (the walls must
  close: every end of a wall's bottom edge meets the end of exactly one other wall);
- :func:`inside` / :func:`check_cameras`: points on the floor inside the room; cameras inside the
  room (a camera outside it, or no camera at all, is an :class:`~pipeline.errors.InputError`);
- :func:`wall_blocks`: whether the straight line from a camera to a point crosses a wall
  (matters for rooms that are not convex, e.g. an L-shaped CAVE);
- :func:`regions`: floor cells labelled centre / inner / edges / corners by their distance to the
  walls (for a 3 m x 3 m CAVE and a 0.5 m band: the centre 1 m x 1 m square, the ring around it
  up to 1 m from the walls, the 0.5 m strip along one wall, and the 0.5 m x 0.5 m corner squares
  near two walls, as ``scripts/bench_triangulation.py`` groups its 6 x 6 cells).

Displays that lie flat (a floor or ceiling screen) bound nothing and are ignored here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.camera import Camera
from pipeline.cave import CaveGeometry, Wall
from pipeline.errors import InputError

F64 = NDArray[np.float64]
B = NDArray[np.bool_]

#: wall ends closer than this (metres, on the floor) meet.
JOINT_TOLERANCE_M = 0.05
REGIONS: tuple[str, ...] = ("centre", "inner", "edges", "corners")


@dataclass(frozen=True, slots=True)
class Room:
    """The floor and the standing walls of a CAVE.

    polygon_xy: (V, 2) floor polygon, metres, counter-clockwise seen from above, not repeated at the end.
    walls: the vertical walls (flat floor/ceiling displays left out).
    height_m: the tallest wall's top.
    """

    polygon_xy: F64
    walls: tuple[Wall, ...]
    height_m: float

    def __post_init__(self) -> None:
        p = np.asarray(self.polygon_xy, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 2 or len(p) < 3:
            raise ValueError(f"polygon_xy must be (V >= 3, 2), got {p.shape}")
        object.__setattr__(self, "polygon_xy", p)

    @property
    def edges(self) -> tuple[F64, F64]:
        """((V, 2) start, (V, 2) end) of the polygon's edges."""
        return self.polygon_xy, np.roll(self.polygon_xy, -1, axis=0)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(x_min, y_min, x_max, y_max) of the floor."""
        lo, hi = self.polygon_xy.min(axis=0), self.polygon_xy.max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])

    @property
    def centroid_xy(self) -> F64:
        """(2,) area centroid of the floor polygon."""
        p, q = self.edges
        cross = p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]
        area = cross.sum() / 2.0
        c: F64 = ((p + q) * cross[:, None]).sum(axis=0) / (6.0 * area)
        return c


def _bottom_edge(wall: Wall) -> tuple[F64, F64]:
    """(2,) and (2,) floor positions of a vertical wall's two lowest corners."""
    c = wall.corners_m
    low = np.argsort(c[:, 2], kind="stable")[:2]
    return c[low[0], :2].copy(), c[low[1], :2].copy()


def floor_polygon(cave: CaveGeometry) -> Room:
    """The closed floor polygon of the CAVE's vertical walls.

    Raises InputError when the walls do not close (a wall end meeting no other wall, or more than
    one), when they form more than one loop, or when fewer than three walls stand.
    """
    vertical = tuple(w for w in cave.walls if abs(float(w.normal[2])) < 0.1)
    if len(vertical) < 3:
        names = ", ".join(w.name for w in cave.walls)
        raise InputError(
            f"the walls do not close: a room needs at least three vertical walls, "
            f"got {len(vertical)} ({names})"
        )
    ends = [_bottom_edge(w) for w in vertical]
    pts = np.array([e for pair in ends for e in pair])  # (2W, 2): wall k's ends are 2k, 2k + 1
    d = np.linalg.norm(pts[:, None, :] - pts[None, :, :], axis=2)
    np.fill_diagonal(d, np.inf)
    for k in range(len(vertical)):
        d[2 * k, 2 * k + 1] = d[2 * k + 1, 2 * k] = np.inf
    partner = np.full(len(pts), -1)
    for i in range(len(pts)):
        near = np.flatnonzero(d[i] < JOINT_TOLERANCE_M)
        wall = vertical[i // 2]
        end = pts[i]
        if near.size == 0:
            raise InputError(
                f"the walls do not close: wall {wall.name!r} ends at ({end[0]:.2f}, {end[1]:.2f}) m "
                f"where no other wall starts"
            )
        if near.size > 1:
            others = ", ".join(repr(vertical[j // 2].name) for j in near)
            raise InputError(
                f"the walls do not close into one room: at ({end[0]:.2f}, {end[1]:.2f}) m wall "
                f"{wall.name!r} meets {others}"
            )
        partner[i] = near[0]
    # Walk the loop: leave each wall by its other end, enter the next wall at the partner end.
    order: list[int] = []
    polygon: list[F64] = []
    i = 0
    seen_walls: set[int] = set()
    while (i // 2) not in seen_walls:
        seen_walls.add(i // 2)
        order.append(i // 2)
        polygon.append((pts[i] + pts[partner[i]]) / 2.0)
        i = int(partner[i ^ 1])
    if len(seen_walls) != len(vertical):
        missing = ", ".join(repr(vertical[k].name) for k in range(len(vertical)) if k not in seen_walls)
        raise InputError(f"the walls do not close into one room: {missing} form a separate loop")
    poly = np.array(polygon)
    p, q = poly, np.roll(poly, -1, axis=0)
    area = float((p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]).sum()) / 2.0
    if abs(area) < 0.25:
        raise InputError(f"the walls enclose {abs(area):.2f} m² of floor; a CAVE needs more than 0.25 m²")
    if area < 0:
        poly = poly[::-1]
    height = float(max(w.corners_m[:, 2].max() for w in vertical))
    return Room(poly.copy(), tuple(vertical[k] for k in order), height)


def inside(room: Room, xy: F64) -> B:
    """(...,) True where (..., 2) floor points lie inside the floor polygon (ray casting)."""
    pts = np.asarray(xy, dtype=np.float64)
    x, y = pts[..., 0, None], pts[..., 1, None]
    a, b = room.edges
    ax, ay, bx, by = a[:, 0], a[:, 1], b[:, 0], b[:, 1]
    crosses = (ay > y) != (by > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_at = ax + (y - ay) * (bx - ax) / (by - ay)
    out: B = (np.count_nonzero(crosses & (x < x_at), axis=-1) % 2) == 1
    return out


def wall_distances(room: Room, xy: F64) -> F64:
    """(..., V) distance of (..., 2) floor points to each of the polygon's edges, metres."""
    pts = np.asarray(xy, dtype=np.float64)[..., None, :]
    a, b = room.edges
    ab = b - a
    s = np.clip(((pts - a) * ab).sum(axis=-1) / (ab * ab).sum(axis=-1), 0.0, 1.0)
    closest = a + s[..., None] * ab
    d: F64 = np.linalg.norm(pts - closest, axis=-1)
    return d


def check_cameras(
    room: Room,
    cameras: Sequence[Camera],
    *,
    above_walls_m: float = 0.5,
    tolerance_m: float = JOINT_TOLERANCE_M,
) -> None:
    """Raise InputError unless there are at least two cameras and each hangs inside the room.

    Inside: over the floor polygon (or within ``tolerance_m`` of its edge, a camera on a wall), and
    between the floor and ``above_walls_m`` above the walls' top (a camera on the wall frame).
    """
    if not cameras:
        raise InputError("a plan needs cameras: got zero cameras")
    if len(cameras) < 2:
        raise InputError(
            f"a plan needs at least two cameras (triangulation needs two views), got {len(cameras)}"
        )
    for cam in cameras:
        c = cam.center_m
        on_floor = bool(inside(room, c[:2])) or float(wall_distances(room, c[:2]).min()) <= tolerance_m
        top = room.height_m + above_walls_m
        if not on_floor or not 0.0 < c[2] <= top:
            x0, y0, x1, y1 = room.bounds
            raise InputError(
                f"camera {cam.name} at ({c[0]:.2f}, {c[1]:.2f}, {c[2]:.2f}) m is outside the room "
                f"(floor x {x0:.2f}..{x1:.2f}, y {y0:.2f}..{y1:.2f} m, height 0..{top:.2f} m in the CAVE "
                f"frame); is the calibration in the CAVE frame?"
            )


def wall_blocks(room: Room, eye_m: F64, points_m: F64) -> B:
    """(...,) True where the segment from ``eye_m`` (3,) to (..., 3) points crosses a wall rectangle."""
    pts = np.asarray(points_m, dtype=np.float64)
    eye = np.asarray(eye_m, dtype=np.float64)
    out = np.zeros(pts.shape[:-1], dtype=bool)
    for wall in room.walls:
        c = wall.corners_m
        n = wall.normal
        d0 = float(n @ c[0])
        s_eye = float(n @ eye) - d0
        s_pts = pts @ n - d0
        cross = s_eye * s_pts < -1e-9
        if not np.any(cross):
            continue
        t = np.where(cross, s_eye / np.where(cross, s_eye - s_pts, 1.0), 0.0)
        q = eye + t[..., None] * (pts - eye)
        u, v = c[1] - c[0], c[3] - c[0]
        a = ((q - c[0]) @ u) / float(u @ u)
        b = ((q - c[0]) @ v) / float(v @ v)
        out |= cross & (a > 0.0) & (a < 1.0) & (b > 0.0) & (b < 1.0)
    return out


def regions(room: Room, xy: F64, band_m: float) -> NDArray[np.str_]:
    """(...,) region name of each (..., 2) floor point: ``corners`` within ``band_m`` of two or more
    walls, ``edges`` within it of one, ``inner`` within 2 x ``band_m``, else ``centre``."""
    d = wall_distances(room, xy)
    near = np.count_nonzero(d < band_m, axis=-1)
    nearest = d.min(axis=-1)
    out = np.where(
        near >= 2, "corners", np.where(near == 1, "edges", np.where(nearest < 2 * band_m, "inner", "centre"))
    )
    return out
