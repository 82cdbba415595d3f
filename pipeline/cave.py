"""The CAVE's geometry: walls as 3D corner points in the CAVE frame (SPEC.md conventions).

CAVE frame: right-handed, metres, origin on the floor at the CAVE's centre, +Z up,
+Y towards the front wall, +X towards the right wall.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError

F64 = NDArray[np.float64]


@dataclass(frozen=True, slots=True, eq=False)
class Wall:
    """A flat rectangular display wall.

    corners_m: (4, 3) corners in the CAVE frame, in the order top-left, top-right,
    bottom-right, bottom-left *as seen by a user standing inside the CAVE facing the wall*
    (the order an image shown on the wall has its corners in).
    resolution_px: (width, height) of the picture the workstation shows on this wall.
    """

    name: str
    corners_m: F64
    resolution_px: tuple[int, int] = (1920, 1600)

    def __post_init__(self) -> None:
        c = np.asarray(self.corners_m, dtype=np.float64)
        if c.shape != (4, 3) or not np.all(np.isfinite(c)):
            raise InputError(f"wall {self.name}: corners must be 4 finite [x, y, z] points")
        u = c[1] - c[0]
        v = c[3] - c[0]
        if np.linalg.norm(u) < 1e-3 or np.linalg.norm(v) < 1e-3:
            raise InputError(f"wall {self.name}: corners are degenerate")
        normal = np.cross(u, v)
        if abs(np.dot(normal / np.linalg.norm(normal), c[2] - c[0])) > 1e-3:
            raise InputError(f"wall {self.name}: corners are not coplanar")
        if not np.allclose(c[0] + (c[2] - c[1]), c[3], atol=1e-3):
            raise InputError(f"wall {self.name}: corners do not form a rectangle")
        w, h = (int(x) for x in self.resolution_px)
        if w <= 0 or h <= 0:
            raise InputError(f"wall {self.name}: resolution must be positive")
        object.__setattr__(self, "corners_m", c)
        object.__setattr__(self, "resolution_px", (w, h))

    @property
    def width_m(self) -> float:
        return float(np.linalg.norm(self.corners_m[1] - self.corners_m[0]))

    @property
    def height_m(self) -> float:
        return float(np.linalg.norm(self.corners_m[3] - self.corners_m[0]))

    @property
    def normal(self) -> F64:
        """Unit normal pointing into the CAVE (towards the viewer)."""
        c = self.corners_m
        # (TR - TL) x (BL - TL) is "right x down" = the viewing direction, i.e. out of the CAVE.
        n = np.cross(c[3] - c[0], c[1] - c[0])
        normal: F64 = n / np.linalg.norm(n)
        return normal

    def point_at(self, u: F64, v: F64) -> F64:
        """3D points at fractional wall coordinates u (left->right), v (top->bottom) in [0, 1]."""
        c = self.corners_m
        u_arr = np.asarray(u, dtype=np.float64)[..., None]
        v_arr = np.asarray(v, dtype=np.float64)[..., None]
        return c[0] + u_arr * (c[1] - c[0]) + v_arr * (c[3] - c[0])


@dataclass(frozen=True, slots=True)
class CaveGeometry:
    """The walls of the CAVE and the extent of its floor."""

    walls: tuple[Wall, ...]
    floor_half_size_m: tuple[float, float] = (1.5, 1.5)

    def __post_init__(self) -> None:
        names = [w.name for w in self.walls]
        if len(set(names)) != len(names):
            raise InputError(f"wall names must be unique, got {names}")
        if not self.walls:
            raise InputError("a CAVE needs at least one wall")

    def wall(self, name: str) -> Wall:
        for w in self.walls:
            if w.name == name:
                return w
        raise InputError(f"unknown wall {name!r}; walls are {', '.join(w.name for w in self.walls)}")

    @property
    def height_m(self) -> float:
        return float(max(w.corners_m[:, 2].max() for w in self.walls))


def box_cave(width_m: float = 3.0, depth_m: float = 3.0, height_m: float = 2.5,
             resolution_px: tuple[int, int] = (1920, 1600)) -> CaveGeometry:
    """A four-wall CAVE (front, right, back, left) around a width x depth floor centred on the origin."""
    if min(width_m, depth_m, height_m) <= 0:
        raise InputError("CAVE width, depth and height must be positive")
    x, y, h = width_m / 2, depth_m / 2, height_m
    # Corners as seen from inside: top-left, top-right, bottom-right, bottom-left.
    walls = (
        Wall("front", np.array([[-x, y, h], [x, y, h], [x, y, 0], [-x, y, 0]]), resolution_px),
        Wall("right", np.array([[x, y, h], [x, -y, h], [x, -y, 0], [x, y, 0]]), resolution_px),
        Wall("back", np.array([[x, -y, h], [-x, -y, h], [-x, -y, 0], [x, -y, 0]]), resolution_px),
        Wall("left", np.array([[-x, -y, h], [-x, y, h], [-x, y, 0], [-x, -y, 0]]), resolution_px),
    )
    return CaveGeometry(walls=walls, floor_half_size_m=(x, y))
