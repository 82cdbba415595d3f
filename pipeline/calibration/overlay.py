"""Validation overlays: what the operator looks at to trust a camera's calibration.

Per camera: the CAVE's wall outlines, the detected corners (green), the reprojected
corners (red crosses; rejected observations in orange), and the X-Y-Z axes of the
CAVE frame drawn at its origin (red, green, blue), as in the paper's figure.
"""

from __future__ import annotations

import itertools

import cv2
import numpy as np
from numpy.typing import NDArray

from pipeline.calibration.pnp import CameraCalibration
from pipeline.camera import Camera, project
from pipeline.cave import CaveGeometry
from pipeline.errors import InputError

F64 = NDArray[np.float64]
U8 = NDArray[np.uint8]

_GREEN, _RED, _BLUE, _ORANGE, _YELLOW = (0, 200, 0), (0, 0, 255), (255, 80, 0), (0, 140, 255), (0, 230, 230)


def _bgr(image: U8 | None, cam: Camera) -> U8:
    w, h = cam.image_size
    if image is None:
        return np.full((h, w, 3), 40, np.uint8)
    img = np.asarray(image)
    if img.dtype != np.uint8 or img.shape[:2] != (h, w):
        raise InputError(
            f"overlay for {cam.name}: expected a {w}x{h} 8-bit image, got {img.dtype} {img.shape}"
        )
    if img.ndim == 2:
        return np.asarray(cv2.cvtColor(img, cv2.COLOR_GRAY2BGR), dtype=np.uint8)
    return img[..., :3].copy()


def _polyline(
    img: U8, cam: Camera, points_m: F64, color: tuple[int, int, int], thickness: int, samples: int = 40
) -> None:
    """Draw a 3D polyline, densely sampled so lens distortion bends it as the camera sees it."""
    pts = np.asarray(points_m, dtype=np.float64)
    dense = np.concatenate(
        [
            a + np.linspace(0.0, 1.0, samples, endpoint=False)[:, None] * (b - a)
            for a, b in itertools.pairwise(pts)
        ]
        + [pts[-1:]]
    )
    uv = project(cam, dense)
    ok = np.all(np.isfinite(uv), axis=1) & (np.abs(uv) < 1e5).all(axis=1)
    # Draw each run of visible (in front of the camera) samples.
    start = None
    for i in range(len(uv) + 1):
        if i < len(uv) and ok[i]:
            start = i if start is None else start
            continue
        if start is not None and i - start >= 2:
            seg = np.round(uv[start:i] * 16).astype(np.int32).reshape(-1, 1, 2)
            cv2.polylines(img, [seg], False, color, thickness, cv2.LINE_AA, shift=4)
        start = None


def _scale(cam: Camera) -> int:
    return max(1, round(max(cam.image_size) / 900))


def draw_axes(img: U8, cam: Camera, length_m: float = 0.5) -> None:
    """The CAVE frame's X (red), Y (green), Z (blue) axes from the origin, with labels."""
    s = _scale(cam)
    o = np.zeros(3)
    for axis, color, label in ((0, _RED, "X"), (1, _GREEN, "Y"), (2, _BLUE, "Z")):
        end = np.zeros(3)
        end[axis] = length_m
        _polyline(img, cam, np.stack([o, end]), color, 3 * s)
        tip = project(cam, end[None])[0]
        if np.all(np.isfinite(tip)):
            cv2.putText(
                img,
                label,
                (int(tip[0]) + 4 * s, int(tip[1]) - 4 * s),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.7 * s,
                color,
                2 * s,
                cv2.LINE_AA,
            )


def draw_walls(img: U8, cam: Camera, cave: CaveGeometry) -> None:
    """Every wall's outline (yellow)."""
    for wall in cave.walls:
        _polyline(img, cam, np.vstack([wall.corners_m, wall.corners_m[:1]]), _YELLOW, 2 * _scale(cam))


def calibration_overlay(result: CameraCalibration, cave: CaveGeometry, image: U8 | None = None) -> U8:
    """(H, W, 3) BGR validation image of one calibrated camera (on its own image, or on grey)."""
    cam = result.camera
    img = _bgr(image, cam)
    s = _scale(cam)
    draw_walls(img, cam, cave)
    reproj = result.reprojected_px
    for det, rep, used in zip(result.image_points_px, reproj, result.inliers, strict=True):
        if np.all(np.isfinite(det)):
            cv2.circle(
                img,
                (round(det[0] * 16), round(det[1] * 16)),
                64 * s,
                _GREEN if used else _ORANGE,
                s,
                cv2.LINE_AA,
                shift=4,
            )
        if np.all(np.isfinite(rep)):
            cv2.drawMarker(
                img, (round(float(rep[0])), round(float(rep[1]))), _RED, cv2.MARKER_CROSS, 6 * s, s
            )
    draw_axes(img, cam)
    text = (
        f"{cam.name}  RMS {result.rms_px:.2f} px  {result.markers_used} markers  "
        f"walls: {', '.join(result.walls_seen)}  [{result.verdict}]"
    )
    draw_caption(img, text, s)
    return img


def draw_caption(img: U8, text: str, scale: int = 1) -> None:
    """White text on a dark band across the top left, in place: readable on the white walls too."""
    font, size, thick = cv2.FONT_HERSHEY_SIMPLEX, 0.8 * scale, 2 * scale
    (w, h), base = cv2.getTextSize(text, font, size, thick)
    pad = 8 * scale
    x0, y0 = 4 * scale, 4 * scale
    x1, y1 = min(img.shape[1], x0 + w + 2 * pad), min(img.shape[0], y0 + h + base + 2 * pad)
    band = img[y0:y1, x0:x1]
    band[:] = (band.astype(np.float32) * 0.2 + np.array([39, 24, 17], np.float32) * 0.8).astype(np.uint8)
    cv2.putText(img, text, (x0 + pad, y0 + pad + h), font, size, (255, 255, 255), thick, cv2.LINE_AA)


def encode_png(image: U8) -> bytes:
    """PNG bytes of an image (what the app serves)."""
    ok, buf = cv2.imencode(".png", image)
    if not ok:
        raise InputError("could not encode the overlay as PNG")
    return bytes(buf.tobytes())
