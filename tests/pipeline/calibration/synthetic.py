"""Camera views of the wall patterns for the calibration tests, rendered by the simulator.

``pipeline.sim.walls`` warps each wall's pattern into a camera exactly (lens distortion
included) and adds a real capture's imperfections; the tests use its default cameras,
scaled to 1280x720 and rendered at one sample per pixel to stay fast.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pipeline.calibration.patterns import MarkerLayout, render_wall_pattern
from pipeline.camera import Camera
from pipeline.cave import CaveGeometry
from pipeline.sim.scene import default_cameras
from pipeline.sim.walls import WallRenderConfig, render_camera_view

SIZE = (1280, 720)


def small_cameras(cave: CaveGeometry, count: int = 4) -> list[Camera]:
    """The simulator's default Kinect-colour cameras, scaled from 1920x1080 to 1280x720."""
    out = []
    for cam in default_cameras(cave, "kinect_color", count):
        s = SIZE[0] / cam.image_size[0]
        K = cam.K.copy()
        K[:2, :2] *= s
        K[:2, 2] = (K[:2, 2] + 0.5) * s - 0.5
        out.append(Camera(cam.name, SIZE, K, cam.dist, cam.R, cam.t))
    return out


def render(
    cam: Camera, cave: CaveGeometry, layout: MarkerLayout, seed: int, walls: tuple[str, ...] | None = None
) -> NDArray[np.uint8]:
    """(H, W, 3) BGR view of the walls (only ``walls`` show their pattern when given)."""
    patterns = {name: render_wall_pattern(cave, layout, name) for name in (walls or layout.walls)}
    rng = np.random.default_rng(seed)
    return render_camera_view(cam, cave, layout, rng, WallRenderConfig(supersample=1), patterns)
