"""Dashboard snapshots: a camera's newest frame (or a plain canvas for the simulator's
virtual cameras) with the detected skeletons drawn over it, as JPEG."""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

from pipeline.pixels import to_bgr
from pipeline.pose.types import ViewDetections
from pipeline.skeleton import BONES

CANVAS_BGR = (48, 40, 36)
COLOURS = ((0, 200, 255), (80, 220, 80), (255, 160, 60), (200, 90, 255), (90, 90, 255))


def render_snapshot(image: NDArray[np.uint8] | None, view: ViewDetections | None, long_side: int = 640,
                    min_score: float = 0.3, quality: int = 80) -> bytes:
    """JPEG bytes of ``image`` (BGR or I420; or a canvas of the view's size) scaled to ``long_side``,
    skeletons drawn."""
    if image is not None:
        image = to_bgr(image)
    if image is None:
        if view is None:
            raise ValueError("need an image or a view to draw")
        w, h = view.image_size
        image = np.empty((h, w, 3), np.uint8)
        image[:] = CANVAS_BGR
    h, w = image.shape[:2]
    scale = min(1.0, long_side / max(h, w))
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    out = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    if view is not None:
        draw_skeletons(out, view, scale, min_score)
    ok, data = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:
        raise ValueError("JPEG encoding failed")
    return bytes(data.tobytes())


def draw_skeletons(image: NDArray[np.uint8], view: ViewDetections, scale: float, min_score: float) -> None:
    """Draw every person's bones and joints in place (coordinates scaled by ``scale``)."""
    for p in range(len(view)):
        colour = COLOURS[p % len(COLOURS)]
        kp = view.keypoints_xy[p] * scale
        sc = view.keypoint_scores[p]
        ok = (sc >= min_score) & np.all(np.isfinite(kp), axis=1)
        for a, b in BONES:
            if ok[a] and ok[b]:
                cv2.line(image, (int(kp[a, 0]), int(kp[a, 1])), (int(kp[b, 0]), int(kp[b, 1])), colour, 2,
                         cv2.LINE_AA)
        for j in np.flatnonzero(ok):
            cv2.circle(image, (int(kp[j, 0]), int(kp[j, 1])), 3, colour, -1, cv2.LINE_AA)
        x1, y1, x2, y2 = (view.boxes_xyxy[p] * scale).astype(int).tolist()
        cv2.rectangle(image, (x1, y1), (x2, y2), colour, 1)
