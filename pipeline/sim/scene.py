"""The simulated CAVE scene: virtual cameras placed as in the paper (one above each wall).

Presets (intrinsics as the devices ship them, approximately):

- ``kinect_color``: Kinect-v2-like colour camera, 1920x1080, fx = fy = 1060 (84 x 54 deg).
- ``depth``: Azure-Kinect-like depth camera (NFOV), 640x576, fx = fy = 505 (65 x 59 deg).

Both have a small radial-tangential distortion, as a calibrated real lens does.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pipeline.camera import Camera, look_at
from pipeline.cave import CaveGeometry
from pipeline.errors import InputError
from pipeline.sim.config import PRESETS

F64 = NDArray[np.float64]


CAMERA_HEIGHT_M = 2.3
TARGET_HEIGHT_M = 1.0
INSET_M = 0.15  # cameras hang this far inside the wall plane


def camera_positions(cave: CaveGeometry, count: int, height_m: float = CAMERA_HEIGHT_M) -> list[F64]:
    """Camera centres: above the top-edge centre of each wall, then above the walls' corners."""
    top = cave.height_m
    z = min(height_m, top - 0.05) if top > 0.5 else height_m
    spots: list[F64] = []
    for wall in cave.walls:
        c = wall.corners_m
        mid = (c[0] + c[1]) / 2.0
        inward = (
            wall.normal if float(wall.normal @ (np.array([0.0, 0.0, mid[2]]) - mid)) > 0 else -wall.normal
        )
        p = mid + inward * INSET_M
        spots.append(np.array([p[0], p[1], z]))
    for wall in cave.walls:
        c = wall.corners_m[0]
        xy = c[:2] - INSET_M * np.sign(c[:2])
        spots.append(np.array([xy[0], xy[1], z]))
    if not 1 <= count <= len(spots):
        raise InputError(f"camera count must be 1..{len(spots)} for this CAVE, got {count}")
    return spots[:count]


def default_cameras(
    cave: CaveGeometry,
    preset: str = "kinect_color",
    count: int = 4,
    *,
    height_m: float = CAMERA_HEIGHT_M,
    target_height_m: float = TARGET_HEIGHT_M,
    rng: np.random.Generator | None = None,
    jitter_m: float = 0.0,
    jitter_deg: float = 0.0,
) -> list[Camera]:
    """One camera above each wall looking at the CAVE centre at ``target_height_m``; named cam01...

    With ``rng``, each camera's position and aim are jittered by up to ``jitter_m`` / ``jitter_deg``
    (a real installation is never exactly where the plan says).
    """
    if preset not in PRESETS:
        raise InputError(f"unknown camera preset {preset!r}; presets are {', '.join(PRESETS)}")
    p = PRESETS[preset]
    cams = []
    for i, eye in enumerate(camera_positions(cave, count, height_m)):
        target = np.array([0.0, 0.0, target_height_m])
        if rng is not None:
            eye = eye + rng.uniform(-jitter_m, jitter_m, 3)
            dist = np.linalg.norm(target - eye)
            target = target + rng.uniform(-1.0, 1.0, 3) * dist * np.tan(np.radians(jitter_deg))
        R, t = look_at(eye, target)
        cams.append(Camera(f"cam{i + 1:02d}", p.image_size, p.K(), np.asarray(p.dist), R, t))
    return cams
