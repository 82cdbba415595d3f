"""The classic path: a camera's intrinsics from checkerboard images (for labs without display walls).

Corners are found on a half-size copy (OpenCV's classic detector, then the sector-based
one), refined to sub-pixel at full resolution, and ``cv2.calibrateCamera`` solves K and
distortion over every usable image. Pose2Sim's demo ships such a set
(``calibration/intrinsics/int_camXX_img``, 4x7 inner corners, 60 mm squares).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from pipeline.camera import Camera
from pipeline.errors import CalibrationError, InputError

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]
U8 = NDArray[np.uint8]

IMAGE_SUFFIXES = {".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff"}


@dataclass(frozen=True, slots=True)
class BoardSpec:
    """A checkerboard: inner corners (n1, n2) — either order — and the square size in metres."""

    corners: tuple[int, int] = (4, 7)
    square_m: float = 0.060

    def __post_init__(self) -> None:
        a, b = (int(v) for v in self.corners)
        if a < 2 or b < 2:
            raise InputError(f"a checkerboard needs at least 2x2 inner corners, got {self.corners}")
        if not self.square_m > 0:
            raise InputError(f"checkerboard square size must be positive, got {self.square_m} m")
        object.__setattr__(self, "corners", (a, b))

    def object_points(self, pattern: tuple[int, int]) -> F64:
        """(N, 3) board-frame corners for OpenCV's pattern size (columns, rows), z = 0."""
        cols, rows = pattern
        grid = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2).astype(np.float64)
        return np.hstack([grid * self.square_m, np.zeros((len(grid), 1))])


@dataclass(frozen=True, slots=True, eq=False)
class IntrinsicsCalibration:
    """Intrinsics of one camera from checkerboard images.

    camera: K and distortion (pose = identity: a checkerboard gives no CAVE pose).
    rms_px: RMS reprojection error over all corners, pixels.
    images_used: image files whose board was found; images_skipped: the others.
    """

    camera: Camera
    rms_px: float
    images_used: tuple[Path, ...]
    images_skipped: tuple[Path, ...]

    def summary(self) -> str:
        k = self.camera.K
        return (
            f"{self.camera.name}: RMS {self.rms_px:.3f} px over {len(self.images_used)} images "
            f"({len(self.images_skipped)} without a usable board), f = {k[0, 0]:.1f}/{k[1, 1]:.1f} px, "
            f"c = ({k[0, 2]:.1f}, {k[1, 2]:.1f}), k1 = {self.camera.dist[0]:.4f}"
        )


def find_board(gray: U8, board: BoardSpec) -> tuple[tuple[int, int], F64] | None:
    """The board's pattern size (columns, rows) and (N, 2) sub-pixel corners, or None if not found."""
    small = cv2.resize(gray, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA)
    a, b = board.corners
    for pattern in ((a, b), (b, a)):
        flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_FAST_CHECK
        ok, corners = cv2.findChessboardCorners(small, pattern, flags=flags)
        if not ok:
            ok, corners = cv2.findChessboardCornersSB(small, pattern, flags=cv2.CALIB_CB_EXHAUSTIVE)
        if ok and corners is not None:
            full = (corners.reshape(-1, 1, 2) * 2.0 + 0.5).astype(
                np.float32
            )  # half-size -> full pixel centres
            criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 50, 0.001)
            refined = cv2.cornerSubPix(gray, full, (11, 11), (-1, -1), criteria)
            return pattern, refined.reshape(-1, 2).astype(np.float64)
    return None


def image_files(paths: Sequence[Path]) -> list[Path]:
    """Image files named directly or found in the given folders (sorted)."""
    files: list[Path] = []
    for p in paths:
        if p.is_dir():
            files += sorted(f for f in p.iterdir() if f.suffix.lower() in IMAGE_SUFFIXES)
        elif p.is_file():
            files.append(p)
        else:
            raise InputError(f"checkerboard images not found: {p}")
    if not files:
        raise InputError(f"no images ({', '.join(sorted(IMAGE_SUFFIXES))}) in {', '.join(map(str, paths))}")
    return files


def calibrate_intrinsics(name: str, paths: Sequence[Path], board: BoardSpec) -> IntrinsicsCalibration:
    """K and distortion of one camera from its checkerboard images (files or folders)."""
    files = image_files(paths)
    obj: list[NDArray[np.float32]] = []
    img: list[NDArray[np.float32]] = []
    used: list[Path] = []
    skipped: list[Path] = []
    size: tuple[int, int] | None = None
    for f in files:
        gray = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)
        if gray is None:
            raise InputError(f"{name}: cannot read image {f}")
        this_size = (int(gray.shape[1]), int(gray.shape[0]))
        if size is not None and this_size != size:
            raise InputError(f"{name}: {f} is {this_size[0]}x{this_size[1]}, the others {size[0]}x{size[1]}")
        size = this_size
        found = find_board(gray, board)
        if found is None:
            skipped.append(f)
            log.info("%s: no %dx%d board in %s", name, *board.corners, f.name)
            continue
        pattern, corners = found
        obj.append(board.object_points(pattern).astype(np.float32))
        img.append(corners.astype(np.float32))
        used.append(f)
    if size is None or len(used) < 3:
        raise CalibrationError(
            f"camera {name}: the {board.corners[0]}x{board.corners[1]} checkerboard was found in "
            f"{len(used)} of {len(files)} images; need at least 3"
        )
    # Solve, then drop an image whose corners disagree with the others (a mis-ordered or
    # partial detection) and solve again.
    while True:
        rms, K, dist, rvecs, tvecs = cv2.calibrateCamera(
            obj, img, size, np.eye(3), np.zeros(5), flags=cv2.CALIB_FIX_K3
        )
        per_image = np.array(
            [
                float(
                    np.sqrt(
                        np.mean(np.sum((cv2.projectPoints(o, r, t, K, dist)[0].reshape(-1, 2) - i) ** 2, 1))
                    )
                )
                for o, i, r, t in zip(obj, img, rvecs, tvecs, strict=True)
            ]
        )
        worst = int(np.argmax(per_image))
        if len(used) <= 3 or per_image[worst] <= max(1.0, 3.0 * float(np.median(per_image))):
            break
        log.info(
            "%s: dropping %s (RMS %.2f px vs median %.2f)",
            name,
            used[worst].name,
            per_image[worst],
            float(np.median(per_image)),
        )
        skipped.append(used.pop(worst))
        obj.pop(worst)
        img.pop(worst)
    cam = Camera(name, size, np.asarray(K), np.asarray(dist).ravel()[:5], np.eye(3), np.zeros(3), float(rms))
    result = IntrinsicsCalibration(cam, float(rms), tuple(used), tuple(skipped))
    log.info("%s", result.summary())
    return result
