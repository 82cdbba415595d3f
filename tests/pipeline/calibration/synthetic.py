"""A minimal camera-view renderer of the wall patterns, for tests and the calibration benchmark.

For each camera pixel: undistort to a viewing ray, intersect it with every wall
plane, keep the nearest wall hit inside the wall, and sample that wall's pattern
(pixel-edge convention of pipeline.calibration.patterns). 2x supersampled, then
display contrast, optical blur and sensor noise. Ground truth is the Camera given.
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

from pipeline.calibration.patterns import MarkerLayout, render_wall_pattern
from pipeline.camera import Camera, intrinsics, look_at, undistort_points
from pipeline.cave import CaveGeometry

U8 = NDArray[np.uint8]


def render_view(
    cam: Camera,
    cave: CaveGeometry,
    layout: MarkerLayout,
    rng: np.random.Generator | None = None,
    blur_sigma_px: float = 0.7,
    noise_sigma: float = 2.0,
    supersample: int = 2,
    walls: tuple[str, ...] | None = None,
) -> U8:
    """The (H, W) uint8 grey image the camera sees of the walls showing their patterns."""
    w, h = cam.image_size
    s = supersample
    # Viewing rays (undistorted normalised coordinates) are smooth: solve them on a coarse
    # grid and interpolate to the supersampled grid.
    step = 8
    gx = np.arange(-step, w + 2 * step, step, dtype=np.float64)
    gy = np.arange(-step, h + 2 * step, step, dtype=np.float64)
    coarse = undistort_points(cam, np.stack(np.meshgrid(gx, gy), axis=-1))  # (Gy, Gx, 2)
    xs = (np.arange(w * s) + 0.5) / s - 0.5
    ys = (np.arange(h * s) + 0.5) / s - 0.5
    fx, fy = (xs - gx[0]) / step, (ys - gy[0]) / step
    ix, iy = np.floor(fx).astype(int), np.floor(fy).astype(int)
    ax, ay = (fx - ix)[None, :, None], (fy - iy)[:, None, None]
    along_x = coarse[:, ix] * (1 - ax) + coarse[:, ix + 1] * ax  # (Gy, W*s, 2)
    rays = along_x[iy] * (1 - ay) + along_x[iy + 1] * ay  # (H*s, W*s, 2)
    x, y = rays[..., 0], rays[..., 1]
    origin = cam.center_m

    def dot(a: NDArray[np.float64]) -> NDArray[np.float64]:
        """d . a for every pixel's world ray d = R^T [x, y, 1]."""
        ra = cam.R @ a
        return x * ra[0] + y * ra[1] + ra[2]

    best_t = np.full(x.shape, np.inf)
    canvas = np.full(x.shape, 60.0, np.float32)  # floor / ceiling / gaps: dim grey
    for wall in cave.walls:
        if walls is not None and wall.name not in walls:
            continue
        c0 = wall.corners_m[0]
        eu, ev, n = wall.corners_m[1] - c0, wall.corners_m[3] - c0, wall.normal
        ww, wh = wall.resolution_px
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((c0 - origin) @ n) / dot(n)
            u = ((origin - c0) @ eu + t * dot(eu)) * (ww / float(eu @ eu))
            v = ((origin - c0) @ ev + t * dot(ev)) * (wh / float(ev @ ev))
        sel = (t > 0) & (t < best_t) & (u >= 0) & (u <= ww) & (v >= 0) & (v <= wh)
        best_t[sel] = t[sel]
        if not layout.on_wall(wall.name):
            canvas[sel] = 225.0
            continue
        pattern = render_wall_pattern(cave, layout, wall.name).astype(np.float32)
        sx = np.where(sel, u - 0.5, -1.0).astype(np.float32)
        sy = np.where(sel, v - 0.5, -1.0).astype(np.float32)
        sampled = cv2.remap(pattern, sx, sy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        canvas[sel] = 35.0 + sampled[sel] * ((225.0 - 35.0) / 255.0)  # display contrast
    img = canvas
    img = cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA)
    if blur_sigma_px > 0:
        img = cv2.GaussianBlur(img, (0, 0), blur_sigma_px)
    if rng is not None and noise_sigma > 0:
        img = img + rng.normal(0.0, noise_sigma, img.shape).astype(np.float32)
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


def corner_cameras(
    cave: CaveGeometry,
    image_size: tuple[int, int] = (1920, 1080),
    hfov_deg: float = 84.0,
    k1: float = 0.04,
    k2: float = -0.02,
) -> list[Camera]:
    """Four cameras high in the CAVE's corners, each looking across at the two opposite walls."""
    hx, hy = cave.floor_half_size_m
    height = cave.height_m
    w, h = image_size
    f = (w / 2) / np.tan(np.deg2rad(hfov_deg) / 2)
    cams = []
    for i, (sx, sy) in enumerate([(1, 1), (1, -1), (-1, -1), (-1, 1)]):
        eye = np.array([sx * (hx - 0.15), sy * (hy - 0.15), height - 0.2])
        target = np.array([-sx * 0.5, -sy * 0.5, 0.9])
        R, t = look_at(eye, target)
        K = intrinsics(
            f * (1 + 0.01 * i), f * (1 + 0.01 * i), (w - 1) / 2 + 6 - 3 * i, (h - 1) / 2 - 4 + 2 * i
        )
        cams.append(Camera(f"cam{i + 1:02d}", image_size, K, [k1, k2, 0.0, 0.0, 0.0], R, t))
    return cams
