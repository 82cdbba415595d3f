"""Rendered wall images for calibration: each camera's view of the walls showing the ArUco patterns.

For every pixel of a virtual camera the renderer undistorts the pixel to its viewing ray,
intersects the ray with each wall (and the floor), and samples the wall's pattern image
(:func:`pipeline.calibration.patterns.render_wall_pattern`) where the ray hits it first.
This is an exact perspective warp of each pattern, with the camera's lens distortion.
The image is supersampled and area-averaged (no aliasing on marker edges), then gets the
imperfections of a real capture: per-wall brightness and black level (LED walls differ),
a slight colour tint per wall, vignetting, blur and sensor noise.

Pixel conventions: pattern images use the pixel-edge convention of
:mod:`pipeline.calibration.patterns`; camera images use OpenCV's (integer = pixel centre),
the convention of :func:`pipeline.camera.project` and of ArUco's corner detector.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from pipeline.calibration.patterns import MarkerLayout, render_wall_pattern
from pipeline.camera import Camera, project, undistort_points
from pipeline.cave import CaveGeometry
from pipeline.errors import InputError
from pipeline.sim.scene import default_cameras

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]
U8 = NDArray[np.uint8]

_BAND_ROWS = 512  # rows of the supersampled image processed at once (bounds memory)


@dataclass(frozen=True, slots=True)
class WallRenderConfig:
    """Imperfections of the rendered camera images.

    supersample: render at this many times the resolution, then area-average (anti-aliasing).
    wall_gain: (min, max) per-wall brightness of displayed white (1 = 255).
    black_level: (min, max) per-wall grey level of displayed black (room light, LED glow).
    tint: maximum per-channel colour deviation of a wall.
    vignetting: brightness loss at the image corners (0 = none).
    blur_px: Gaussian blur sigma in camera pixels (optics, focus).
    noise_sd: sensor noise, grey levels.
    floor_grey / background_grey: grey level of the floor and of anything else (ceiling, outside).
    """

    supersample: int = 2
    wall_gain: tuple[float, float] = (0.7, 1.0)
    black_level: tuple[float, float] = (8.0, 40.0)
    tint: float = 0.05
    vignetting: float = 0.2
    blur_px: float = 0.6
    noise_sd: float = 2.0
    floor_grey: float = 70.0
    background_grey: float = 20.0

    def __post_init__(self) -> None:
        if not 1 <= int(self.supersample) <= 4:
            raise InputError(f"supersample must be 1..4, got {self.supersample}")
        lo, hi = self.wall_gain
        if not 0.05 <= lo <= hi <= 1.5:
            raise InputError(f"wall_gain must satisfy 0.05 <= min <= max <= 1.5, got {self.wall_gain}")
        blo, bhi = self.black_level
        if not 0 <= blo <= bhi <= 200:
            raise InputError(f"black_level must satisfy 0 <= min <= max <= 200, got {self.black_level}")
        for name in ("tint", "vignetting", "blur_px", "noise_sd"):
            v = float(getattr(self, name))
            if not np.isfinite(v) or v < 0:
                raise InputError(f"{name} must be >= 0, got {v}")

    @classmethod
    def clean(cls) -> WallRenderConfig:
        """No blur, noise, vignetting or brightness differences (for exactness checks)."""
        return cls(
            wall_gain=(1.0, 1.0), black_level=(0.0, 0.0), tint=0.0, vignetting=0.0, blur_px=0.0, noise_sd=0.0
        )


def marker_corners_px(cam: Camera, layout: MarkerLayout) -> dict[int, F64]:
    """Ground truth: each marker's 4 corners projected into ``cam`` (OpenCV pixel coordinates)."""
    return {m.id: project(cam, m.corners_m) for m in layout.markers}


def _supersampled(cam: Camera, s: int) -> Camera:
    """The same camera at s times the resolution (pixel centres kept consistent)."""
    K = cam.K.copy()
    K[0, 0] *= s
    K[1, 1] *= s
    K[0, 1] *= s
    K[0, 2] = (K[0, 2] + 0.5) * s - 0.5
    K[1, 2] = (K[1, 2] + 0.5) * s - 0.5
    w, h = cam.image_size
    return Camera(cam.name, (w * s, h * s), K, cam.dist, cam.R, cam.t)


def _normalised_grid(cam: Camera, step: int = 8) -> tuple[F32, F32]:
    """Undistorted normalised coordinates (x/z, y/z) of every pixel centre, as two (H, W) float32 maps.

    The distortion is inverted exactly on a grid every ``step`` pixels and interpolated
    bilinearly in between (the inverse is smooth: the error is far below 0.01 px).
    """
    w, h = cam.image_size
    gx = np.arange(0, w + step, step, dtype=np.float64)
    gy = np.arange(0, h + step, step, dtype=np.float64)
    mx, my = np.meshgrid(gx, gy)
    coarse = undistort_points(cam, np.stack([mx, my], axis=-1)).astype(np.float32)
    xs = (np.arange(w, dtype=np.float32) / step)[None, :].repeat(h, axis=0)
    ys = (np.arange(h, dtype=np.float32) / step)[:, None].repeat(w, axis=1)
    qx = cv2.remap(np.ascontiguousarray(coarse[..., 0]), xs, ys, interpolation=cv2.INTER_LINEAR)
    qy = cv2.remap(np.ascontiguousarray(coarse[..., 1]), xs, ys, interpolation=cv2.INTER_LINEAR)
    return np.asarray(qx, dtype=np.float32), np.asarray(qy, dtype=np.float32)


def render_camera_view(
    cam: Camera,
    cave: CaveGeometry,
    layout: MarkerLayout,
    rng: np.random.Generator,
    config: WallRenderConfig | None = None,
    patterns: dict[str, U8] | None = None,
) -> U8:
    """(H, W, 3) uint8 BGR image of the walls showing ``layout``'s patterns, as ``cam`` sees them."""
    cfg = config or WallRenderConfig()
    if patterns is None:
        patterns = {name: render_wall_pattern(cave, layout, name) for name in layout.walls}
    s = int(cfg.supersample)
    hi = _supersampled(cam, s)
    W, H = hi.image_size
    origin = cam.center_m
    walls = [w for w in cave.walls if w.name in patterns]
    gains = rng.uniform(*cfg.wall_gain, len(walls))
    blacks = rng.uniform(*cfg.black_level, len(walls))
    tints = 1.0 + rng.uniform(-cfg.tint, cfg.tint, (len(walls), 3))
    out = np.empty((H, W, 3), dtype=np.float32)
    qx_all, qy_all = _normalised_grid(hi)
    fx, fy = cave.floor_half_size_m
    # Per plane, with q = (x, y, 1) the undistorted normalised coordinates and the ray R^T q:
    # depth t = ((c0 - o) . n) / (q . R n); the hit point's wall coordinates are linear in t q.
    for y0 in range(0, H, _BAND_ROWS):
        qx = qx_all[y0 : y0 + _BAND_ROWS]
        qy = qy_all[y0 : y0 + _BAND_ROWS]
        best = np.full(qx.shape, np.inf, dtype=np.float32)
        band = np.full((*qx.shape, 3), cfg.background_grey, dtype=np.float32)
        floor_n = cam.R @ np.array([0.0, 0.0, 1.0])
        with np.errstate(divide="ignore", invalid="ignore"):
            t_floor = np.float32(-origin[2]) / (qx * floor_n[0] + qy * floor_n[1] + floor_n[2])
        ray = cam.R.T  # columns: world directions of the camera x, y, z axes
        px = origin[0] + t_floor * (qx * ray[0, 0] + qy * ray[0, 1] + ray[0, 2])
        py = origin[1] + t_floor * (qx * ray[1, 0] + qy * ray[1, 1] + ray[1, 2])
        hit = (t_floor > 0) & (np.abs(px) <= fx) & (np.abs(py) <= fy)
        band[hit] = cfg.floor_grey
        best[hit] = t_floor[hit]
        for k, wall in enumerate(walls):
            c = wall.corners_m
            a = cam.R @ wall.normal
            eu, ev = c[1] - c[0], c[3] - c[0]
            pw, ph = wall.resolution_px
            su, sv = cam.R @ eu * (pw / float(eu @ eu)), cam.R @ ev * (ph / float(ev @ ev))
            ou, ov = (
                (origin - c[0]) @ eu * (pw / float(eu @ eu)),
                (origin - c[0]) @ ev * (ph / float(ev @ ev)),
            )
            with np.errstate(divide="ignore", invalid="ignore"):
                t_wall = np.float32((c[0] - origin) @ wall.normal) / (qx * a[0] + qy * a[1] + a[2])
            u = ou + t_wall * (qx * su[0] + qy * su[1] + su[2])
            v = ov + t_wall * (qx * sv[0] + qy * sv[1] + sv[2])
            hit = (t_wall > 0) & (t_wall < best) & (u >= 0) & (u <= pw) & (v >= 0) & (v <= ph)
            if not hit.any():
                continue
            sample = cv2.remap(
                patterns[wall.name],
                (u - 0.5).astype(np.float32),
                (v - 0.5).astype(np.float32),
                interpolation=cv2.INTER_LINEAR,
                borderMode=cv2.BORDER_REPLICATE,
            ).astype(np.float32)
            level = blacks[k] + (gains[k] * 255.0 - blacks[k]) * sample[hit] / 255.0
            band[hit] = level[:, None] * tints[k].astype(np.float32)
            best[hit] = t_wall[hit]
        out[y0 : y0 + len(qx)] = band
    w, h = cam.image_size
    img = cv2.resize(out, (w, h), interpolation=cv2.INTER_AREA) if s > 1 else out
    if cfg.vignetting > 0:
        yy, xx = np.mgrid[0:h, 0:w]
        r2 = ((xx - cam.K[0, 2]) / (w / 2)) ** 2 + ((yy - cam.K[1, 2]) / (h / 2)) ** 2
        img = img * (1.0 - cfg.vignetting * r2 / 2.0)[..., None].astype(np.float32)
    if cfg.blur_px > 0:
        img = cv2.GaussianBlur(img, (0, 0), cfg.blur_px)
    if cfg.noise_sd > 0:
        img = img + rng.normal(0.0, cfg.noise_sd, img.shape).astype(np.float32)
    return np.asarray(np.clip(np.rint(img), 0, 255), dtype=np.uint8)


def render_wall_views(
    cave: CaveGeometry,
    layout: MarkerLayout,
    cameras: Sequence[Camera],
    seed: int = 0,
    config: WallRenderConfig | None = None,
) -> dict[str, U8]:
    """Camera name -> rendered BGR image of the walls, for every camera (ground truth = ``cameras``)."""
    if not cameras:
        raise InputError("no cameras to render the walls for")
    patterns = {name: render_wall_pattern(cave, layout, name) for name in layout.walls}
    rngs = (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(len(cameras)))
    views = {}
    for cam, rng in zip(cameras, rngs, strict=True):
        views[cam.name] = render_camera_view(cam, cave, layout, rng, config, patterns)
        log.debug("rendered the walls for %s", cam.name)
    return views


def simulated_cameras(settings: Any, cave: CaveGeometry) -> list[Camera]:
    """The virtual cameras for settings-like objects (duck-typed: ``.sim.camera_preset`` and
    ``.cameras[i].name``): the default cameras of the preset, named as in the settings."""
    names = [str(c.name) for c in settings.cameras]
    if not names:
        raise InputError("the settings list no cameras")
    cams = default_cameras(cave, str(settings.sim.camera_preset), len(names))
    return [replace(c, name=n) for c, n in zip(cams, names, strict=True)]


def render_camera_views(
    cameras: Sequence[Camera] | Any,
    cave: CaveGeometry,
    layout: MarkerLayout,
    seed: int = 0,
    config: WallRenderConfig | None = None,
) -> dict[str, U8]:
    """Like :func:`render_wall_views`; ``cameras`` may also be a settings-like object
    (see :func:`simulated_cameras`), as the calibration service passes."""
    cams = list(cameras) if isinstance(cameras, list | tuple) else simulated_cameras(cameras, cave)
    return render_wall_views(cave, layout, cams, seed, config)
