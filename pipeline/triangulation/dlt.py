"""Robust multi-view triangulation: weighted DLT, outlier-view rejection, Gauss-Newton refinement.

Everything is vectorised over N points (joints of one or many people) seen by C cameras, with
the fixed-shape convention of aniposelib: ``(C, N, 2)`` pixels in, NaN or score 0 where a camera
did not see a point, ``(N, 3)`` metres out, NaN where a point is unknown.

Pixels are undistorted once to normalised image coordinates (``pipeline.camera.undistort_points``);
the linear system then uses the world-to-camera matrices ``[R | t]``, so lens distortion is handled
exactly and every camera's rows have the same scale. Errors are converted back to pixels with each
camera's focal length (for rejection) or measured by full reprojection with distortion (reported).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from pipeline.camera import Camera, undistort_points
from pipeline.errors import InputError
from pipeline.triangulation.config import TriangulationParams

F64 = NDArray[np.float64]
B = NDArray[np.bool_]

MIN_VIEWS = 2
MIN_DEPTH_M = 1e-3


@dataclass(frozen=True, slots=True, eq=False)
class CameraRig:
    """Cameras stacked as arrays for vectorised triangulation.

    cameras: the C cameras, in the order of the first axis of every (C, ...) array.
    Rt: (C, 3, 4) world-to-camera matrices [R | t] (normalised-coordinate projection).
    focal_px: (C,) mean focal length, pixels per normalised unit.
    """

    cameras: tuple[Camera, ...]
    Rt: F64
    focal_px: F64
    quad: F64 = field(init=False, repr=False)
    K: F64 = field(init=False, repr=False)
    dist: F64 = field(init=False, repr=False)

    def __post_init__(self) -> None:
        c = len(self.cameras)
        if c < 1:
            raise InputError("a camera rig needs at least one camera")
        names = [cam.name for cam in self.cameras]
        if len(set(names)) != c:
            raise InputError(f"camera names must be unique, got {names}")
        if self.Rt.shape != (c, 3, 4) or self.focal_px.shape != (c,):
            raise ValueError(f"Rt must be ({c}, 3, 4) and focal_px ({c},), got "
                             f"{self.Rt.shape} and {self.focal_px.shape}")
        object.__setattr__(self, "quad", _rig_quadratics(self.Rt))
        object.__setattr__(self, "K", np.stack([cam.K for cam in self.cameras]))
        object.__setattr__(self, "dist", np.stack([cam.dist for cam in self.cameras]))

    @classmethod
    def from_cameras(cls, cameras: Sequence[Camera]) -> CameraRig:
        cams = tuple(cameras)
        if not cams:
            raise InputError("a camera rig needs at least one camera")
        rt = np.stack([np.hstack([c.R, c.t[:, None]]) for c in cams]) if cams else np.zeros((0, 3, 4))
        focal = np.array([0.5 * (c.K[0, 0] + c.K[1, 1]) for c in cams], dtype=np.float64)
        return cls(cams, rt, focal)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.cameras)

    def __len__(self) -> int:
        return len(self.cameras)

    def project(self, points_m: F64) -> F64:
        """(N, 3) world points -> (C, N, 2) pixels with distortion (NaN behind a camera).

        The same model as :func:`pipeline.camera.project`, for all cameras at once.
        """
        xy, z = project_normalized(self.Rt, points_m)
        xy[~(z > MIN_DEPTH_M)] = np.nan
        d = self.dist
        k1, k2, p1, p2, k3 = (d[:, i, None] for i in range(5))
        x, y = xy[..., 0], xy[..., 1]
        r2 = x * x + y * y
        radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
        yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
        k = self.K
        u = k[:, 0, 0, None] * xd + k[:, 0, 1, None] * yd + k[:, 0, 2, None]
        v = k[:, 1, 1, None] * yd + k[:, 1, 2, None]
        return np.stack([u, v], axis=2)

    def undistort(self, uv_px: F64) -> F64:
        """(C, N, 2) distorted pixels -> (C, N, 2) undistorted normalised coordinates (NaN kept)."""
        uv = _check_points(uv_px, len(self), "keypoints_px")
        return np.stack([undistort_points(cam, uv[i]) for i, cam in enumerate(self.cameras)])


@dataclass(frozen=True, slots=True)
class Triangulation:
    """The result of :func:`triangulate` for N points.

    points_m: (N, 3) float64 metres, NaN where unknown.
    valid: (N,) bool, True where at least two views agree (after outlier rejection).
    reproj_px: (N,) mean reprojection error over the used views, pixels (NaN where unknown).
    used: (C, N) bool, which views each point was finally triangulated from.
    """

    points_m: F64
    valid: B
    reproj_px: F64
    used: B

    def __post_init__(self) -> None:
        n = self.points_m.shape[0]
        if self.points_m.shape != (n, 3) or self.valid.shape != (n,) or self.reproj_px.shape != (n,):
            raise ValueError(f"inconsistent shapes: points {self.points_m.shape}, valid "
                             f"{self.valid.shape}, reproj {self.reproj_px.shape}")
        if self.used.ndim != 2 or self.used.shape[1] != n:
            raise ValueError(f"used must be (C, {n}), got {self.used.shape}")


def _check_points(arr: object, c: int, what: str) -> F64:
    a = np.asarray(arr, dtype=np.float64)
    if a.ndim != 3 or a.shape[0] != c or a.shape[2] != 2:
        raise InputError(f"{what}: expected shape ({c}, N, 2), got {a.shape}")
    return a


def _weights(xy: F64, scores: object | None, min_score: float) -> F64:
    c, n = xy.shape[:2]
    finite = np.all(np.isfinite(xy), axis=2)
    if scores is None:
        w = np.ones((c, n))
    else:
        w = np.asarray(scores, dtype=np.float64)
        if w.shape != (c, n):
            raise InputError(f"scores: expected shape ({c}, {n}), got {w.shape}")
        w = np.where(np.isfinite(w) & (w >= min_score) & (w > 0), w, 0.0)
    return np.where(finite, w, 0.0)


def _solve3(a: F64, b: F64) -> F64:
    """Batched solve of (N, 3, 3) a x = (N, 3) b; NaN rows where a is singular."""
    try:
        out: F64 = np.asarray(np.linalg.solve(a, b[..., None])[..., 0], dtype=np.float64)
    except np.linalg.LinAlgError:
        out = np.full(b.shape, np.nan)
        for i in range(a.shape[0]):
            try:
                out[i] = np.linalg.solve(a[i], b[i])
            except np.linalg.LinAlgError:
                continue
    return out


def _rig_quadratics(Rt: F64) -> F64:
    """(C, 4, 16) per-camera outer products so that A^T A = sum_c coef_c . quad_c (see below)."""
    p1, p2, p3 = Rt[:, 0, :], Rt[:, 1, :], Rt[:, 2, :]
    outer = np.einsum
    q33 = outer("ci,cj->cij", p3, p3)
    s31 = outer("ci,cj->cij", p3, p1)
    s32 = outer("ci,cj->cij", p3, p2)
    q = np.stack([q33, s31 + s31.transpose(0, 2, 1), s32 + s32.transpose(0, 2, 1),
                  outer("ci,cj->cij", p1, p1) + outer("ci,cj->cij", p2, p2)], axis=1)
    return q.reshape(Rt.shape[0], 4, 16)


def triangulate_linear(Rt: F64, xy: F64, weights: F64, quad: F64 | None = None) -> F64:
    """Weighted linear triangulation (DLT).

    Rt: (C, 3, 4) world-to-camera matrices; xy: (C, N, 2) normalised coordinates;
    weights: (C, N) >= 0 (0 = view not used); quad: ``_rig_quadratics(Rt)`` if precomputed.
    Returns (N, 3), NaN where fewer than two views. Each view adds the rows w (x P3 - P1) and
    w (y P3 - P2) to A; with X = (x, y, z, 1) the least-squares solution of A X = 0 comes from the
    3 x 3 normal equations. A^T A = sum_c w^2 [(x^2 + y^2) P3P3' - x (P3P1' + P1P3')
    - y (P3P2' + P2P3') + P1P1' + P2P2'] is one matrix product with the per-camera quadratics.
    """
    c, n = weights.shape
    q = _rig_quadratics(Rt) if quad is None else quad
    w2 = np.where(weights > 0, weights, 0.0) ** 2
    xy0 = np.where(np.isnan(xy), 0.0, xy)
    x, y = xy0[..., 0], xy0[..., 1]
    coef = np.stack([w2 * (x * x + y * y), -w2 * x, -w2 * y, w2], axis=2)  # (C, N, 4)
    ata = (coef.transpose(1, 0, 2).reshape(n, c * 4) @ q.reshape(c * 4, 16)).reshape(n, 4, 4)
    n_views = np.count_nonzero(w2 > 0, axis=0)
    few = n_views < MIN_VIEWS
    lhs = ata[:, :3, :3]
    if np.any(few):
        lhs = lhs.copy()
        lhs[few] = np.eye(3)
    pts = _solve3(lhs, -ata[:, :3, 3])
    bad = few | ~np.all(np.isfinite(pts), axis=1)
    pts[bad] = np.nan
    return pts


def project_normalized(Rt: F64, points_m: F64) -> tuple[F64, F64]:
    """(N, 3) world points -> ((C, N, 2) normalised coordinates, (C, N) depths in metres)."""
    pc = points_m @ Rt[:, :, :3].transpose(0, 2, 1) + Rt[:, None, :, 3]
    z = pc[..., 2]
    z_safe = np.where(z != 0, z, np.nan)  # NaN instead of a division warning
    xy = pc[..., :2] / z_safe[..., None]
    return xy, z


def normalized_error_px(Rt: F64, focal_px: F64, xy: F64, points_m: F64) -> F64:
    """(C, N) reprojection error in undistorted pixels (normalised error x focal).

    NaN where the point or the observation is unknown, inf where the point is behind the camera.
    """
    proj, z = project_normalized(Rt, points_m)
    d = proj - xy
    err: F64 = np.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2) * focal_px[:, None]
    err[z <= MIN_DEPTH_M] = np.inf
    return err


def refine_gauss_newton(Rt: F64, xy: F64, weights: F64, points_m: F64, iterations: int) -> F64:
    """A few damped Gauss-Newton steps on the weighted squared reprojection error (normalised).

    Vectorised over points; points that are NaN stay NaN. The Jacobian of (X/Z, Y/Z) with respect
    to the world point is ((R0 - u R2) / Z, (R1 - v R2) / Z).
    """
    x = points_m.copy()
    ok = np.all(np.isfinite(x), axis=1)
    if iterations <= 0 or not np.any(ok):
        return x
    rot = Rt[:, :, :3]  # (C, 3, 3)
    rot_t = rot.transpose(0, 2, 1)
    w2 = (weights**2)[:, ok][..., None]  # (C, M, 1)
    obs = xy[:, ok]
    obs = np.where(np.isnan(obs), 0.0, obs)
    xk = x[ok]
    eye = np.eye(3)
    for _ in range(iterations):
        pc = xk @ rot_t + Rt[:, None, :, 3]
        z = pc[..., 2:3]
        z = np.where(np.abs(z) > MIN_DEPTH_M, z, MIN_DEPTH_M)
        u = pc[..., 0:1] / z
        v = pc[..., 1:2] / z
        ju = (rot[:, None, 0, :] - u * rot[:, None, 2, :]) / z  # (C, M, 3)
        jv = (rot[:, None, 1, :] - v * rot[:, None, 2, :]) / z
        wju, wjv = w2 * ju, w2 * jv
        h = (wju[..., :, None] * ju[..., None, :] + wjv[..., :, None] * jv[..., None, :]).sum(axis=0)
        g = (wju * (u - obs[..., 0:1]) + wjv * (v - obs[..., 1:2])).sum(axis=0)
        damp = 1e-9 + 1e-6 * (h[:, 0, 0] + h[:, 1, 1] + h[:, 2, 2])
        xk = xk - _solve3(h + damp[:, None, None] * eye, g)
    x[ok] = np.where(np.isfinite(xk), xk, x[ok])
    return x


def triangulate_normalized(
    rig: CameraRig,
    xy: F64,
    weights: F64,
    params: TriangulationParams,
    min_outlier_px: F64 | float | None = None,
) -> tuple[F64, B, F64]:
    """Robust triangulation on normalised coordinates.

    Returns (points (N, 3), used (C, N), error (C, N) undistorted pixels, inf where unused).
    Outlier views are removed one at a time per point by leave-one-out: for a point with more than
    two views and a residual above ``min_outlier_px`` ((C, N) or a scalar; default
    ``params.outlier_min_px``), each view in turn is left out and the point re-triangulated from
    the others; the subset whose views agree best wins, and the left-out view is dropped when its
    error from that subset exceeds both its ``min_outlier_px`` and ``outlier_ratio`` x the mean
    error of the remaining views. (A plain DLT spreads one bad view's
    error over all views, so the worst residual of the all-view solution does not stand out enough.)
    """
    Rt, focal_px, quad = rig.Rt, rig.focal_px, rig.quad
    w = weights.copy()
    c = w.shape[0]
    floor = np.broadcast_to(
        np.asarray(params.outlier_min_px if min_outlier_px is None else min_outlier_px, dtype=np.float64),
        w.shape,
    )
    pts = triangulate_linear(Rt, xy, w, quad)
    for _ in range(max(0, c - MIN_VIEWS)):
        used = w > 0
        err_all = normalized_error_px(Rt, focal_px, xy, pts)
        suspect = np.any(used & ~(err_all <= floor), axis=0)
        idx = np.flatnonzero((used.sum(axis=0) > MIN_VIEWS) & suspect)
        if idx.size == 0:
            break
        m = idx.size
        wi, xyi, ui = w[:, idx], xy[:, idx], used[:, idx]
        # (C, C*M): block k = the weights with view k left out.
        w_blocks = np.tile(wi, (1, c)).reshape(c, c, m)
        w_blocks[np.arange(c), np.arange(c)] = 0.0
        w_loo = w_blocks.reshape(c, c * m)
        xy_loo = np.tile(xyi, (1, c, 1))
        pts_loo = triangulate_linear(Rt, xy_loo, w_loo, quad)
        err = normalized_error_px(Rt, focal_px, xy_loo, pts_loo).reshape(c, c, m)
        rest = (w_loo > 0).reshape(c, c, m)  # [view, left-out k, point]
        rest_mean = np.where(rest, err, 0.0).sum(axis=0) / np.maximum(rest.sum(axis=0), 1)  # (C, M)
        rest_mean = np.where(ui & np.all(np.isfinite(pts_loo), axis=1).reshape(c, m), rest_mean, np.inf)
        rest_mean = np.where(np.isnan(rest_mean), np.inf, rest_mean)
        best = np.argmin(rest_mean, axis=0)  # (M,)
        cols = np.arange(m)
        e_out = err[best, best, cols]
        e_rest = rest_mean[best, cols]
        drop = (
            np.isfinite(e_rest)
            & ~(e_out <= floor[best, idx])
            & ~(e_out <= params.outlier_ratio * e_rest)
        )
        if not np.any(drop):
            break
        sel = idx[drop]
        w[best[drop], sel] = 0.0
        pts[sel] = pts_loo.reshape(c, m, 3)[best[drop], cols[drop]]
    pts = refine_gauss_newton(Rt, xy, w, pts, params.refine_iterations)
    used = w > 0
    err_final = np.where(used, normalized_error_px(Rt, focal_px, xy, pts), np.inf)
    return pts, used, err_final


def reprojection_error(cameras: Sequence[Camera] | CameraRig, points_m: F64, keypoints_px: F64) -> F64:
    """(C, N) pixel distance between each camera's projection of ``points_m`` (with distortion) and
    the observed ``keypoints_px`` (C, N, 2); NaN where either is unknown or behind the camera."""
    rig = cameras if isinstance(cameras, CameraRig) else CameraRig.from_cameras(cameras)
    pts = np.asarray(points_m, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"points_m: expected shape (N, 3), got {pts.shape}")
    uv = _check_points(keypoints_px, len(rig), "keypoints_px")
    if uv.shape[1] != pts.shape[0]:
        raise InputError(f"keypoints_px has {uv.shape[1]} points for {pts.shape[0]} 3D points")
    d = rig.project(pts) - uv
    err: F64 = np.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2)
    return err


def triangulate(
    rig: CameraRig,
    keypoints_px: F64,
    scores: F64 | None = None,
    params: TriangulationParams | None = None,
    *,
    normalized: F64 | None = None,
    scale_px: F64 | None = None,
) -> Triangulation:
    """Triangulate N points seen by the rig's C cameras.

    keypoints_px: (C, N, 2) distorted pixels, NaN where a camera did not see the point.
    scores: (C, N) confidences in [0, 1] (weights of the DLT rows; below ``params.min_score`` =
        unseen); None = all observed points weigh 1.
    normalized: the same points already undistorted (``rig.undistort``), to skip that step.
    scale_px: (C, N) size of the person in each view (pixels, e.g. the keypoints' extent); a view
        is only dropped as an outlier when its error exceeds ``outlier_min_frac`` x this (and
        ``outlier_min_px``), so ordinary detector noise on a large person never drops a view.
    A point is valid when at least two views remain after outlier rejection, it lies in front of
    them, and its mean reprojection error (pixels, with distortion) is at most ``max_reproj_px``.
    """
    p = params or TriangulationParams()
    uv = _check_points(keypoints_px, len(rig), "keypoints_px")
    xy = rig.undistort(uv) if normalized is None else _check_points(normalized, len(rig), "normalized")
    if xy.shape != uv.shape:
        raise InputError(f"normalized {xy.shape} and keypoints_px {uv.shape} differ")
    w = _weights(uv, scores, p.min_score)
    floor: F64 | float = p.outlier_min_px
    if scale_px is not None:
        scale = np.asarray(scale_px, dtype=np.float64)
        if scale.shape != w.shape:
            raise InputError(f"scale_px: expected shape {w.shape}, got {scale.shape}")
        floor = np.maximum(p.outlier_min_px, p.outlier_min_frac * np.where(np.isfinite(scale), scale, 0.0))
    pts, used, err_und = triangulate_normalized(rig, xy, w, p, floor)
    n_used = used.sum(axis=0)
    in_front = np.all(np.isfinite(err_und) | ~used, axis=0)
    err = reprojection_error(rig, np.where(np.isfinite(pts), pts, 0.0), uv)
    mean_err = np.where(used, err, 0.0).sum(axis=0) / np.maximum(n_used, 1)
    finite = np.all(np.isfinite(pts), axis=1)
    valid = finite & in_front & (n_used >= MIN_VIEWS) & (mean_err <= p.max_reproj_px)
    points = np.where(valid[:, None], pts, np.nan)
    return Triangulation(points, valid, np.where(valid, mean_err, np.nan), used & valid[None, :])
