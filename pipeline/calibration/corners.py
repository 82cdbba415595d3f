"""Marker corners from the marker's edges: sub-pixel edge points, a line per edge, corners where lines meet.

A corner refined from a small window around the corner itself (``cornerSubPix``) uses a
few dozen pixels and is biased by blur at the corner's tip; a whole edge uses every pixel
along the marker's border. For each of the four outer edges of a detected marker this
samples the grey-level profile across the edge at many points, finds the gradient peak to
sub-pixel precision, fits a line, and intersects neighbouring lines.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]

_STEP_PX = 0.25  # spacing of the samples across an edge


def _bilinear(img: NDArray[np.float32], x: F64, y: F64) -> F64:
    h, w = img.shape
    x = np.clip(x, 0.0, w - 1.001)
    y = np.clip(y, 0.0, h - 1.001)
    x0, y0 = np.floor(x).astype(np.intp), np.floor(y).astype(np.intp)
    ax, ay = x - x0, y - y0
    top = img[y0, x0] * (1 - ax) + img[y0, x0 + 1] * ax
    bottom = img[y0 + 1, x0] * (1 - ax) + img[y0 + 1, x0 + 1] * ax
    out: F64 = (top * (1 - ay) + bottom * ay).astype(np.float64)
    return out


def _edge_line(img: NDArray[np.float32], a: F64, b: F64, module_px: float) -> tuple[F64, F64] | None:
    """(point, unit direction) of the marker edge from a to b, or None when the edge is not clean.

    Across the edge the image goes from the white quiet zone to the one-module black border:
    the edge is where each profile crosses the grey level halfway between the two (for a
    symmetric blur, exactly at the step), found by linear interpolation between samples.
    """
    length = float(np.linalg.norm(b - a))
    if length < 6.0 or module_px < 1.5:
        return None
    d = (b - a) / length
    n = np.array([-d[1], d[0]])
    count = int(np.clip(length / 1.5, 6, 60))
    along = a + np.linspace(0.15, 0.85, count)[:, None] * (b - a)  # away from the corners
    reach = 0.75 * module_px
    offsets = np.arange(-reach, reach + 1e-9, _STEP_PX)
    pts = along[:, None, :] + offsets[None, :, None] * n  # (count, S, 2)
    profile = _bilinear(img, pts[..., 0].ravel(), pts[..., 1].ravel()).reshape(pts.shape[:2])
    outer = offsets <= -0.5 * module_px
    inner = offsets >= 0.4 * module_px
    if not outer.any() or not inner.any():
        return None
    light, dark = profile[:, outer].mean(axis=1), profile[:, inner].mean(axis=1)
    if np.mean(light) < np.mean(dark):  # n pointed outwards: flip the profiles
        profile, light, dark = profile[:, ::-1], dark, light
        n = -n
    contrast = light - dark
    mid = (light + dark) / 2.0
    above = profile > mid[:, None]
    centre_i = len(offsets) // 2
    keep, cross = [], []
    for r in range(count):
        if contrast[r] < 0.5 * np.median(contrast) or contrast[r] <= 0:
            continue
        # light -> dark transitions; take the one nearest the expected edge (offset 0)
        idx = np.nonzero(above[r, :-1] & ~above[r, 1:])[0]
        if len(idx) == 0:
            continue
        i = int(idx[np.argmin(np.abs(idx - centre_i))])
        p0, p1 = profile[r, i], profile[r, i + 1]
        frac = (p0 - mid[r]) / (p0 - p1) if p0 != p1 else 0.5
        keep.append(r)
        cross.append(offsets[i] + frac * _STEP_PX)
    if len(keep) < 4:
        return None
    edge_pts = along[keep] + np.asarray(cross)[:, None] * n
    centre = edge_pts.mean(axis=0)
    direction = np.linalg.svd(edge_pts - centre)[2][0]
    residual = (edge_pts - centre) @ np.array([-direction[1], direction[0]])
    if np.sqrt(np.mean(residual**2)) > 0.5:  # not a straight clean edge (occluded, out of frame)
        return None
    return centre, direction


def _intersect(p1: F64, d1: F64, p2: F64, d2: F64) -> F64 | None:
    A = np.array([d1, -d2]).T
    if abs(np.linalg.det(A)) < 1e-6:
        return None
    s = np.linalg.solve(A, p2 - p1)
    point: F64 = p1 + s[0] * d1
    return point


def refine_corners_by_edges(
    gray: NDArray[np.uint8], corners_px: F64, bits: int = 4, max_shift_px: float = 1.5
) -> F64:
    """(M, 4, 2) ArUco corners -> corners at the intersections of the fitted outer edges.

    ``bits`` is the dictionary's marker size (4 for 4x4); a marker is bits + 2 modules wide.
    A marker whose edges are not all clean, or whose corners would move by more than
    ``max_shift_px``, keeps its input corners.
    """
    img = np.asarray(gray, dtype=np.float32)
    out = np.array(corners_px, dtype=np.float64, copy=True).reshape(-1, 4, 2)
    for m, quad in enumerate(out.copy()):
        side = float(np.mean(np.linalg.norm(quad - np.roll(quad, -1, axis=0), axis=1)))
        module = side / (bits + 2)
        found = [_edge_line(img, quad[k], quad[(k + 1) % 4], module) for k in range(4)]
        lines = [line for line in found if line is not None]
        if len(lines) < 4:
            continue
        refined = []
        for k in range(4):
            corner = _intersect(lines[k - 1][0], lines[k - 1][1], lines[k][0], lines[k][1])
            if corner is None:
                break
            refined.append(corner)
        if len(refined) == 4:
            new = np.stack(refined)
            if np.max(np.linalg.norm(new - quad, axis=1)) <= max_shift_px:
                out[m] = new
    return out
