"""Dynamic calibration: each camera's intrinsics and pose from the ArUco markers on the walls.

Markers on two or more walls are not coplanar, so one image fixes a camera's
intrinsics as well as its pose:

1. detect the markers (sub-pixel corner refinement) and match their ids to the layout;
2. a first projection matrix by normalised DLT, decomposed into K, R, t (the prior —
   image centre, a nominal focal length — stands in where DLT is not sane);
3. RANSAC PnP with that K rejects gross outliers (a mis-decoded marker);
4. ``cv2.calibrateCamera`` with the intrinsic guess refines intrinsics, distortion and
   pose jointly (Levenberg–Marquardt), then corners beyond ``ransac_px`` are dropped
   and the refinement runs once more.

Several images of a fixed camera (e.g. frames of a short clip) are pooled into one view.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np
from numpy.typing import NDArray

from pipeline.calibration.config import CalibrationConfig, CornerRefinement
from pipeline.calibration.corners import refine_corners_by_edges
from pipeline.calibration.patterns import MarkerLayout, aruco_dictionary
from pipeline.camera import Camera, project
from pipeline.errors import CalibrationError, InputError

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
U8 = NDArray[np.uint8]

Verdict = Literal["good", "fair", "poor"]


@dataclass(frozen=True, slots=True)
class MarkerDetections:
    """The markers found in one camera image.

    image_size: (width, height) of the image, pixels.
    ids: (M,) int64 marker ids.
    corners_px: (M, 4, 2) float64 corners in OpenCV pixel coordinates, ArUco order (TL, TR, BR, BL).
    """

    image_size: tuple[int, int]
    ids: I64
    corners_px: F64

    def __post_init__(self) -> None:
        ids = np.asarray(self.ids, dtype=np.int64).reshape(-1)
        corners = np.asarray(self.corners_px, dtype=np.float64).reshape(-1, 4, 2)
        if corners.shape[0] != ids.shape[0]:
            raise ValueError(
                f"expected one (4, 2) corner set per id, got {corners.shape} for {ids.shape[0]} ids"
            )
        object.__setattr__(self, "ids", ids)
        object.__setattr__(self, "corners_px", corners)
        object.__setattr__(self, "image_size", (int(self.image_size[0]), int(self.image_size[1])))


@dataclass(frozen=True, slots=True, eq=False)
class CameraCalibration:
    """One camera solved from the wall markers, with what the operator needs to judge it.

    camera: the calibrated camera (its rms_px set).
    rms_px: RMS reprojection error over the corners used, pixels.
    markers_used / corners_used: distinct markers / corner observations kept.
    corners_rejected: corner observations dropped as outliers.
    walls_seen: names of the walls whose markers were used.
    images_used: how many images of this camera were pooled.
    coverage: fraction of the image inside the convex hull of the corners used (0..1).
    verdict: ``good`` / ``fair`` / ``poor`` from the RMS thresholds and the coverage.
    object_points_m: (N, 3) CAVE-frame corners of every observation (used and rejected).
    image_points_px: (N, 2) their detected positions, pixels.
    inliers: (N,) bool, True where the observation was used.
    """

    camera: Camera
    rms_px: float
    markers_used: int
    corners_used: int
    corners_rejected: int
    walls_seen: tuple[str, ...]
    images_used: int
    coverage: float
    verdict: Verdict
    object_points_m: F64
    image_points_px: F64
    inliers: NDArray[np.bool_]

    def __post_init__(self) -> None:
        n = len(self.inliers)
        if self.object_points_m.shape != (n, 3) or self.image_points_px.shape != (n, 2):
            raise ValueError(
                f"expected (N, 3) object points and (N, 2) image points for N = {n} inlier flags, "
                f"got {self.object_points_m.shape} and {self.image_points_px.shape}"
            )
        if self.verdict not in ("good", "fair", "poor"):
            raise ValueError(f"verdict must be good, fair or poor, got {self.verdict!r}")

    @property
    def reprojected_px(self) -> F64:
        """(N, 2) the observations' corners projected with the solved camera."""
        uv: F64 = project(self.camera, self.object_points_m)
        return uv

    def summary(self) -> str:
        c = self.camera
        return (
            f"{c.name}: RMS {self.rms_px:.3f} px, {self.markers_used} markers "
            f"on {len(self.walls_seen)} walls "
            f"({', '.join(self.walls_seen)}), f = {c.K[0, 0]:.1f}/{c.K[1, 1]:.1f} px, "
            f"at ({c.center_m[0]:.3f}, {c.center_m[1]:.3f}, {c.center_m[2]:.3f}) m -> {self.verdict}"
        )


# ---------------------------------------------------------------- detection


def _detector(dictionary: str) -> cv2.aruco.ArucoDetector:
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    params.cornerRefinementWinSize = 4
    params.cornerRefinementMaxIterations = 50
    params.cornerRefinementMinAccuracy = 0.005
    return cv2.aruco.ArucoDetector(aruco_dictionary(dictionary), params)


def _gray(image: U8) -> U8:
    img = np.asarray(image)
    if img.dtype != np.uint8 or img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] not in (1, 3, 4)):
        raise InputError(f"expected an 8-bit grey or BGR image, got {img.dtype} of shape {img.shape}")
    if img.ndim == 3 and img.shape[2] == 3:
        return np.asarray(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY), dtype=np.uint8)
    if img.ndim == 3 and img.shape[2] == 4:
        return np.asarray(cv2.cvtColor(img, cv2.COLOR_BGRA2GRAY), dtype=np.uint8)
    return img.reshape(img.shape[0], img.shape[1])


def detect_markers(
    image: U8, dictionary: str = "DICT_4X4_250", refinement: CornerRefinement = "subpix"
) -> MarkerDetections:
    """Find the ArUco markers of ``dictionary`` in an image, with sub-pixel corners.

    refinement: ``subpix`` (OpenCV's corner refinement) or ``edges`` (corners where the
    marker's fitted outer edges meet; see :mod:`pipeline.calibration.corners`).
    """
    gray = _gray(image)
    corners, ids, _ = _detector(dictionary).detectMarkers(gray)
    size = (int(gray.shape[1]), int(gray.shape[0]))
    if ids is None or len(ids) == 0:
        return MarkerDetections(size, np.empty(0, np.int64), np.empty((0, 4, 2)))
    quads = np.stack([c.reshape(4, 2) for c in corners]).astype(np.float64)
    if refinement == "edges":
        quads = refine_corners_by_edges(gray, quads, bits=aruco_dictionary(dictionary).markerSize)
    return MarkerDetections(size, np.asarray(ids).reshape(-1), quads)


# ---------------------------------------------------------------- math


def match_layout(
    detections: Sequence[MarkerDetections], layout: MarkerLayout
) -> tuple[F64, F64, I64, tuple[str, ...]]:
    """Pool the images' detections and pair every corner with its CAVE-frame point.

    Returns object points (N, 3), image points (N, 2), the marker id of each (N,),
    and the names of every wall seen. Ids not in the layout are ignored.
    """
    obj, img, ids = [], [], []
    for det in detections:
        for marker_id, corners in zip(det.ids, det.corners_px, strict=True):
            marker = layout.marker(int(marker_id))
            if marker is None:
                continue
            obj.append(marker.corners_m)
            img.append(corners)
            ids.append(np.full(4, int(marker_id)))
    if not obj:
        return np.empty((0, 3)), np.empty((0, 2)), np.empty(0, np.int64), ()
    id_arr = np.concatenate(ids).astype(np.int64)
    walls = tuple(
        dict.fromkeys(m.wall for m in (layout.marker(int(i)) for i in id_arr[::4]) if m is not None)
    )
    return np.concatenate(obj), np.concatenate(img), id_arr, walls


def _normaliser(points: F64) -> F64:
    centre = points.mean(axis=0)
    scale = math.sqrt(points.shape[1]) / max(float(np.mean(np.linalg.norm(points - centre, axis=1))), 1e-12)
    T = np.eye(points.shape[1] + 1)
    T[:-1, :-1] *= scale
    T[:-1, -1] = -scale * centre
    return T


def dlt_projection(object_m: F64, image_px: F64) -> F64:
    """(3, 4) projection matrix by Hartley-normalised DLT from >= 6 non-coplanar correspondences."""
    if len(object_m) < 6:
        raise CalibrationError(f"DLT needs at least 6 points, got {len(object_m)}")
    T3, T2 = _normaliser(object_m), _normaliser(image_px)
    X = np.hstack([object_m, np.ones((len(object_m), 1))]) @ T3.T
    x = np.hstack([image_px, np.ones((len(image_px), 1))]) @ T2.T
    zeros = np.zeros_like(X)
    A = np.concatenate(
        [
            np.hstack([X, zeros, -x[:, :1] * X]),
            np.hstack([zeros, X, -x[:, 1:2] * X]),
        ]
    )
    Pn = np.linalg.svd(A)[2][-1].reshape(3, 4)
    P: F64 = np.linalg.inv(T2) @ Pn @ T3
    return P


def decompose_projection(P: F64) -> tuple[F64, F64, F64]:
    """P = K [R | t] -> (K with K[2, 2] = 1 and a positive diagonal, R (proper rotation), t)."""
    M = P[:, :3]
    sign = 1.0 if np.linalg.det(M) > 0 else -1.0
    M, p4 = sign * M, sign * P[:, 3]
    # RQ decomposition of M via QR of the flipped transpose.
    flip = np.flipud(np.eye(3))
    q, r = np.linalg.qr((flip @ M).T)
    K = flip @ r.T @ flip
    R = flip @ q.T
    D = np.diag(np.sign(np.diag(K)))
    K, R = K @ D, D @ R
    t = np.linalg.solve(K, p4)
    if np.linalg.det(R) < 0:  # cannot happen with det(M) > 0 and a positive diagonal, but be safe
        R, t = -R, -t
    return K / K[2, 2], R, t


def _prior_k(image_size: tuple[int, int], config: CalibrationConfig) -> F64:
    w, h = image_size
    f = config.focal_prior_px or (w / 2.0) / math.tan(math.radians(config.nominal_hfov_deg) / 2.0)
    return np.array([[f, 0.0, (w - 1) / 2.0], [0.0, f, (h - 1) / 2.0], [0.0, 0.0, 1.0]])


def initial_intrinsics(
    object_m: F64, image_px: F64, image_size: tuple[int, int], config: CalibrationConfig
) -> F64:
    """K to start from: DLT's where it is sane (square-ish pixels, centre near the middle), else the prior."""
    prior = _prior_k(image_size, config)
    try:
        K, _, _ = decompose_projection(dlt_projection(object_m, image_px))
    except (CalibrationError, np.linalg.LinAlgError):
        return prior
    w, h = image_size
    fx, fy = K[0, 0], K[1, 1]
    sane = (
        fx > 0.1 * w
        and fy > 0.1 * w
        and 0.8 < fx / fy < 1.25
        and fx < 20 * w
        and abs(K[0, 2] - w / 2) < 0.3 * w
        and abs(K[1, 2] - h / 2) < 0.3 * h
    )
    if not sane:
        log.debug("DLT intrinsics not sane (%s); using the prior", np.round(K, 1).tolist())
        return prior
    f = math.sqrt(fx * fy)
    return np.array([[f, 0.0, K[0, 2]], [0.0, f, K[1, 2]], [0.0, 0.0, 1.0]])


def _coverage(points_px: F64, image_size: tuple[int, int]) -> float:
    if len(points_px) < 3:
        return 0.0
    hull = cv2.convexHull(points_px.astype(np.float32))
    return float(cv2.contourArea(hull)) / float(image_size[0] * image_size[1])


def _verdict(rms: float, coverage: float, config: CalibrationConfig) -> Verdict:
    if rms <= config.good_rms_px and coverage >= 0.15:
        return "good"
    if rms <= config.fair_rms_px:
        return "fair"
    return "poor"


def _refine(
    obj: F64, img: F64, K0: F64, image_size: tuple[int, int], rvec: F64, tvec: F64, k3: bool
) -> tuple[F64, F64, F64, F64]:
    """Joint Levenberg-Marquardt refinement of intrinsics, distortion and pose (one pooled view)."""
    flags = cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_USE_EXTRINSIC_GUESS | (0 if k3 else cv2.CALIB_FIX_K3)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    _, K, dist, rvecs, tvecs = cv2.calibrateCamera(
        [obj.astype(np.float32)],
        [img.astype(np.float32)],
        image_size,
        K0.copy(),
        np.zeros(5),
        [rvec.reshape(3, 1).copy()],
        [tvec.reshape(3, 1).copy()],
        flags=flags,
        criteria=criteria,
    )
    return (
        np.asarray(K),
        np.asarray(dist).ravel()[:5],
        np.asarray(rvecs[0]).ravel(),
        np.asarray(tvecs[0]).ravel(),
    )


def _need_message(
    name: str, markers: int, walls: tuple[str, ...], config: CalibrationConfig, what: str = "sees"
) -> str | None:
    problems = []
    if markers < config.min_markers:
        problems.append(f"{markers} usable markers (need at least {config.min_markers})")
    if len(walls) < config.min_walls:
        seen = ", ".join(walls) if walls else "none"
        problems.append(
            f"markers on {len(walls)} wall(s) ({seen}); need markers on at least {config.min_walls} walls, "
            "since one flat wall cannot fix the intrinsics — turn or move the camera to see a second wall"
        )
    if not problems:
        return None
    return f"camera {name} {what} " + " and ".join(problems)


def calibrate_camera(
    name: str,
    detections: Sequence[MarkerDetections],
    layout: MarkerLayout,
    config: CalibrationConfig | None = None,
) -> CameraCalibration:
    """Solve one camera from its images' marker detections; CalibrationError says what is missing."""
    cfg = config or CalibrationConfig()
    if not detections:
        raise InputError(f"camera {name}: no images given")
    sizes = {d.image_size for d in detections}
    if len(sizes) != 1:
        raise InputError(f"camera {name}: all images must have the same size, got {sorted(sizes)}")
    image_size = detections[0].image_size
    obj, img, ids, walls = match_layout(detections, layout)
    message = _need_message(name, len(set(ids.tolist())), walls, cfg)
    if message:
        raise CalibrationError(message)

    K0 = initial_intrinsics(obj, img, image_size, cfg)
    # Gross outliers (a mis-decoded or foreign marker) are far off even under the rough K0.
    ok, rvec, tvec, inl = cv2.solvePnPRansac(
        obj,
        img,
        K0,
        None,
        iterationsCount=300,
        reprojectionError=max(4 * cfg.ransac_px, 0.01 * image_size[0]),
        confidence=0.999,
        flags=cv2.SOLVEPNP_EPNP,
    )
    if not ok or inl is None or len(inl) < 6:
        raise CalibrationError(f"camera {name}: no consistent pose from {len(obj)} marker corners")
    inliers = np.zeros(len(obj), bool)
    inliers[np.asarray(inl).ravel()] = True
    rvec, tvec = cv2.solvePnPRefineLM(obj[inliers], img[inliers], K0, None, rvec, tvec)

    k3 = cfg.estimate_k3 and len(set(ids.tolist())) >= 3 * cfg.min_markers
    K, dist, rvec, tvec = _refine(obj[inliers], img[inliers], K0, image_size, rvec, tvec, k3)
    for _ in range(3):
        cam = Camera(name, image_size, K, dist, cv2.Rodrigues(rvec)[0], tvec)
        err = np.linalg.norm(project(cam, obj) - img, axis=1)
        new_inliers = np.isfinite(err) & (err <= cfg.ransac_px)
        if np.array_equal(new_inliers, inliers):
            break
        inliers = new_inliers
        used_walls = _walls_of(ids[inliers], layout)
        message = _need_message(name, len(set(ids[inliers].tolist())), used_walls, cfg, "keeps only")
        if message:
            raise CalibrationError(message + " after rejecting outlier corners")
        K, dist, rvec, tvec = _refine(obj[inliers], img[inliers], K, image_size, rvec, tvec, k3)

    cam = Camera(name, image_size, K, dist, cv2.Rodrigues(rvec)[0], tvec)
    err = np.linalg.norm(project(cam, obj[inliers]) - img[inliers], axis=1)
    rms = float(np.sqrt(np.mean(err**2)))
    cam = Camera(name, image_size, K, dist, cam.R, tvec, rms)
    coverage = _coverage(img[inliers], image_size)
    result = CameraCalibration(
        camera=cam,
        rms_px=rms,
        markers_used=len(set(ids[inliers].tolist())),
        corners_used=int(inliers.sum()),
        corners_rejected=int((~inliers).sum()),
        walls_seen=_walls_of(ids[inliers], layout),
        images_used=len(detections),
        coverage=coverage,
        verdict=_verdict(rms, coverage, cfg),
        object_points_m=obj,
        image_points_px=img,
        inliers=inliers,
    )
    log.info("%s", result.summary())
    return result


def _walls_of(ids: I64, layout: MarkerLayout) -> tuple[str, ...]:
    walls = (layout.marker(int(i)) for i in dict.fromkeys(ids.tolist()))
    return tuple(dict.fromkeys(m.wall for m in walls if m is not None))


def calibrate_cameras(
    images: Mapping[str, Sequence[U8]],
    layout: MarkerLayout,
    config: CalibrationConfig | None = None,
) -> dict[str, CameraCalibration]:
    """Calibrate every camera from its images; one CalibrationError lists every camera that failed."""
    cfg = config or CalibrationConfig()
    if not images:
        raise InputError("no camera images given")
    results: dict[str, CameraCalibration] = {}
    failures: list[str] = []
    for name, imgs in images.items():
        if not imgs:
            raise InputError(f"camera {name}: no images given")
        detections = [detect_markers(img, layout.dictionary, cfg.corner_refinement) for img in imgs]
        try:
            results[name] = calibrate_camera(name, detections, layout, cfg)
        except CalibrationError as exc:
            failures.append(str(exc))
    if failures:
        raise CalibrationError("; ".join(failures))
    return results
