"""The OpenCV pinhole camera model of SPEC.md and the pure functions on it.

``K`` is 3x3, ``dist`` = [k1, k2, p1, p2, k3], and the world-to-camera pose is
``x_cam = R @ x_world + t`` with ``t`` in metres. World = the CAVE frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError

F64 = NDArray[np.float64]


def _as_matrix(value: object, shape: tuple[int, ...], what: str) -> F64:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{what}: expected numbers of shape {shape}") from exc
    if arr.size == int(np.prod(shape)) and arr.shape != shape:
        arr = arr.reshape(shape)
    if arr.shape != shape:
        raise InputError(f"{what}: expected shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{what}: contains NaN or infinite values")
    return arr


@dataclass(frozen=True, slots=True, eq=False)
class Camera:
    """One calibrated camera.

    name: unique camera name (e.g. ``cam01``).
    image_size: (width, height) in pixels.
    K: (3, 3) intrinsic matrix, pixels.
    dist: (5,) OpenCV distortion [k1, k2, p1, p2, k3].
    R: (3, 3) world-to-camera rotation.
    t: (3,) world-to-camera translation, metres.
    rms_px: RMS reprojection error of the calibration, pixels (NaN if unknown).
    """

    name: str
    image_size: tuple[int, int]
    K: F64
    dist: F64
    R: F64
    t: F64
    rms_px: float = float("nan")
    _P: F64 = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not self.name:
            raise InputError("camera name must not be empty")
        w, h = (int(v) for v in self.image_size)
        if w <= 0 or h <= 0:
            raise InputError(f"camera {self.name}: image_size must be positive, got {self.image_size}")
        object.__setattr__(self, "image_size", (w, h))
        object.__setattr__(self, "K", _as_matrix(self.K, (3, 3), f"camera {self.name} K"))
        dist = np.asarray(self.dist, dtype=np.float64).ravel()
        if dist.size < 5:
            dist = np.concatenate([dist, np.zeros(5 - dist.size)])
        object.__setattr__(self, "dist", _as_matrix(dist[:5], (5,), f"camera {self.name} dist"))
        R = _as_matrix(self.R, (3, 3), f"camera {self.name} R")
        if abs(np.linalg.det(R) - 1.0) > 1e-3 or not np.allclose(R @ R.T, np.eye(3), atol=1e-3):
            raise InputError(f"camera {self.name}: R is not a rotation matrix")
        object.__setattr__(self, "R", R)
        object.__setattr__(self, "t", _as_matrix(self.t, (3,), f"camera {self.name} t"))
        object.__setattr__(self, "rms_px", float(self.rms_px))
        object.__setattr__(self, "_P", self.K @ np.hstack([self.R, self.t[:, None]]))

    @property
    def P(self) -> F64:
        """(3, 4) projection matrix K [R | t] (ignores distortion)."""
        return self._P

    @property
    def center_m(self) -> F64:
        """(3,) camera centre in the world frame, metres."""
        center: F64 = -self.R.T @ self.t
        return center

    @property
    def rvec(self) -> F64:
        """(3,) Rodrigues vector of R."""
        rvec: F64 = cv2.Rodrigues(self.R)[0].ravel()
        return rvec

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Camera):
            return NotImplemented
        return (
            self.name == other.name
            and self.image_size == other.image_size
            and all(
                np.allclose(a, b, rtol=1e-9, atol=1e-12)
                for a, b in ((self.K, other.K), (self.dist, other.dist), (self.R, other.R), (self.t, other.t))
            )
        )

    def __hash__(self) -> int:
        return hash((self.name, self.image_size))

    def to_dict(self) -> dict[str, object]:
        """The camera as an entry of the calibration JSON of SPEC.md."""
        return {
            "name": self.name,
            "image_size": list(self.image_size),
            "K": self.K.tolist(),
            "dist": self.dist.tolist(),
            "R": self.R.tolist(),
            "t": self.t.tolist(),
            "rms_px": None if np.isnan(self.rms_px) else self.rms_px,
        }

    @classmethod
    def from_dict(cls, d: dict[str, object]) -> Camera:
        """Build a camera from a calibration-JSON entry; raises InputError naming what is wrong."""
        if not isinstance(d, dict):
            raise InputError("each camera must be a JSON object")
        missing = [k for k in ("name", "image_size", "K", "dist", "R", "t") if k not in d]
        if missing:
            raise InputError(f"camera {d.get('name', '?')}: missing {', '.join(missing)}")
        size = d["image_size"]
        if not isinstance(size, list | tuple) or len(size) != 2:
            raise InputError(f"camera {d['name']}: image_size must be [width, height]")
        rms = d.get("rms_px")
        return cls(
            name=str(d["name"]),
            image_size=(int(size[0]), int(size[1])),
            K=np.asarray(d["K"], dtype=np.float64),
            dist=np.asarray(d["dist"], dtype=np.float64),
            R=np.asarray(d["R"], dtype=np.float64),
            t=np.asarray(d["t"], dtype=np.float64),
            rms_px=float("nan") if rms is None else float(rms),  # type: ignore[arg-type]
        )


def world_to_camera(cam: Camera, points_m: F64) -> F64:
    """(N, 3) world points -> (N, 3) camera-frame points."""
    pts = np.asarray(points_m, dtype=np.float64).reshape(-1, 3)
    return pts @ cam.R.T + cam.t


def distort_normalized(cam: Camera, xy: F64) -> F64:
    """Apply the OpenCV radial-tangential model to (N, 2) normalised image coordinates."""
    k1, k2, p1, p2, k3 = cam.dist
    x, y = xy[:, 0], xy[:, 1]
    r2 = x * x + y * y
    radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.stack([xd, yd], axis=1)


def project(cam: Camera, points_m: F64) -> F64:
    """Project (..., 3) world points to (..., 2) pixels with distortion.

    Points behind the camera (z <= 1 mm) come back as NaN. NaN input stays NaN.
    """
    pts = np.asarray(points_m, dtype=np.float64)
    shape = pts.shape[:-1]
    pc = world_to_camera(cam, pts.reshape(-1, 3))
    z = pc[:, 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        xy = pc[:, :2] / z[:, None]
    xy[~(z > 1e-3)] = np.nan
    xyd = distort_normalized(cam, xy)
    uv = xyd @ cam.K[:2, :2].T + cam.K[:2, 2]
    return uv.reshape(*shape, 2)


def undistort_points(cam: Camera, uv_px: F64) -> F64:
    """(..., 2) distorted pixels -> (..., 2) undistorted normalised coordinates (x/z, y/z).

    NaN input stays NaN. Uses OpenCV's iterative inverse of the distortion model.
    """
    uv = np.asarray(uv_px, dtype=np.float64)
    shape = uv.shape[:-1]
    flat = uv.reshape(-1, 2)
    out = np.full_like(flat, np.nan)
    ok = np.all(np.isfinite(flat), axis=1)
    if np.any(ok):
        if np.any(cam.dist != 0):
            # undistortPoints(src, K, dist, dst, R, P, criteria): OpenCV 4.x named this
            # criteria overload undistortPointsIter; OpenCV 5 folds it into undistortPoints.
            und = cv2.undistortPoints(
                flat[ok].reshape(-1, 1, 2),
                cam.K,
                cam.dist,
                None,
                None,
                None,
                (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 20, 1e-9),
            )
            out[ok] = und.reshape(-1, 2)
        else:
            fx, fy, cx, cy = cam.K[0, 0], cam.K[1, 1], cam.K[0, 2], cam.K[1, 2]
            skew = cam.K[0, 1]
            y = (flat[ok, 1] - cy) / fy
            x = (flat[ok, 0] - cx - skew * y) / fx
            out[ok] = np.stack([x, y], axis=1)
    return out.reshape(*shape, 2)


def look_at(eye_m: F64, target_m: F64, up: F64 | None = None) -> tuple[F64, F64]:
    """World-to-camera (R, t) for a camera at ``eye_m`` looking at ``target_m``.

    Camera axes follow OpenCV: +x right, +y down in the image, +z forward.
    ``up`` is the world up direction (default +Z of the CAVE frame).
    """
    eye = np.asarray(eye_m, dtype=np.float64)
    target = np.asarray(target_m, dtype=np.float64)
    up_v = np.array([0.0, 0.0, 1.0]) if up is None else np.asarray(up, dtype=np.float64)
    z = target - eye
    norm = np.linalg.norm(z)
    if norm < 1e-9:
        raise InputError("look_at: eye and target coincide")
    z /= norm
    x = np.cross(z, up_v)
    if np.linalg.norm(x) < 1e-9:
        raise InputError("look_at: viewing direction is parallel to up")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    t = -R @ eye
    return R, t


def intrinsics(fx: float, fy: float, cx: float, cy: float) -> F64:
    """A 3x3 K matrix."""
    return np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
