"""Dashboard snapshots: a camera's newest frame (or a plain canvas for the simulator's
virtual cameras) with the detected skeletons drawn over it, as JPEG.

With labels (:class:`PersonLabel`, one per detection) each person carries its track id (and user
id) and the navigator is drawn in the dashboard's navigator colour, the others in its "others" one.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from pipeline.pixels import to_bgr
from pipeline.pose.types import ViewDetections
from pipeline.runtime.messages import FusedFrame
from pipeline.skeleton import BONES
from pipeline.tracking.types import TrackedView
from pipeline.triangulation.types import Person3D

CANVAS_BGR = (48, 40, 36)
COLOURS = ((0, 200, 255), (80, 220, 80), (255, 160, 60), (200, 90, 255), (90, 90, 255))
#: The dashboard's legend (frontend/css/dashboard.css --nav, --other), as BGR.
NAVIGATOR_BGR = (0, 140, 255)
OTHER_BGR = (248, 189, 56)
UNTRACKED_BGR = (150, 150, 150)


@dataclass(frozen=True, slots=True)
class PersonLabel:
    """What a detection is drawn as: its text (``"track 4, user 2"``, "" = not tracked) and
    whether it is the navigator."""

    text: str
    navigator: bool = False


def render_snapshot(image: NDArray[np.uint8] | None, view: ViewDetections | None, long_side: int = 640,
                    min_score: float = 0.3, quality: int = 80,
                    labels: list[PersonLabel] | None = None) -> bytes:
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
        draw_skeletons(out, view, scale, min_score, labels)
    ok, data = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:
        raise ValueError("JPEG encoding failed")
    return bytes(data.tobytes())


def draw_skeletons(image: NDArray[np.uint8], view: ViewDetections, scale: float, min_score: float,
                   labels: list[PersonLabel] | None = None) -> None:
    """Draw every person's bones and joints in place (coordinates scaled by ``scale``), and with
    ``labels`` (one per detection) their track ids in the navigator / others colours."""
    for p in range(len(view)):
        label = labels[p] if labels is not None and p < len(labels) else None
        if label is None:
            colour = COLOURS[p % len(COLOURS)]
        else:
            colour = NAVIGATOR_BGR if label.navigator else OTHER_BGR if label.text else UNTRACKED_BGR
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
        if label is not None and label.text:
            _tag(image, label.text, (x1, max(0, y1)), colour)


def _tag(image: NDArray[np.uint8], text: str, corner: tuple[int, int], colour: tuple[int, int, int]) -> None:
    """The label on a filled box of the person's colour above the box's top-left corner."""
    # sized for the dashboard's tiles, which show a 640 px snapshot at about 360 px
    font, size, thick = cv2.FONT_HERSHEY_SIMPLEX, 0.85, 2
    (w, h), base = cv2.getTextSize(text, font, size, thick)
    x, y = corner
    x = min(max(0, x), max(0, image.shape[1] - w - 8))
    top = max(0, y - h - base - 6)
    cv2.rectangle(image, (x, top), (x + w + 8, top + h + base + 6), colour, -1)
    cv2.putText(image, text, (x + 4, top + h + 3), font, size, (20, 20, 20), thick, cv2.LINE_AA)


def person_labels(
    view: ViewDetections, tracked: TrackedView | None, people: Sequence[Person3D], navigator: int | None
) -> list[PersonLabel]:
    """One label per detection of ``view``: its track id in this camera (the tracking stage's
    ``TrackedView`` of the same detections) and its user id (the 3D people's ``views``)."""
    labels = [PersonLabel("") for _ in range(len(view))]
    if tracked is None or len(tracked.detections) != len(view):
        return labels
    users: dict[int, int] = {}
    for person in people:
        for camera, track_id in person.views:
            if camera == view.camera:
                users[int(track_id)] = int(person.user_id)
    for track_id, det in zip(tracked.track_ids.tolist(), tracked.detection_index.tolist(), strict=True):
        if 0 <= det < len(labels):
            user = users.get(int(track_id))
            text = f"track {track_id}" + (f", user {user}" if user is not None else "")  # ASCII (Hershey)
            labels[det] = PersonLabel(text, navigator=user is not None and user == navigator)
    return labels


class SnapshotCache:
    """Each camera's newest JPEG, re-encoded at most every ``interval_s`` (the dashboard's view)."""

    def __init__(self, interval_s: float, long_side: int) -> None:
        self.interval_s = interval_s
        self.long_side = long_side
        self._cached: dict[str, tuple[float, bytes]] = {}

    def clear(self) -> None:
        self._cached.clear()

    def jpeg(self, camera: str, image: NDArray[np.uint8] | None, latest: FusedFrame | None,
             now: float) -> bytes | None:
        """The frame ``image`` (None: a virtual camera, drawn from its detections) with the
        people of ``latest`` drawn; the cached one while it is younger than ``interval_s``."""
        cached = self._cached.get(camera)
        if cached is not None and now - cached[0] < self.interval_s:
            return cached[1]
        views = latest.detected.views if latest is not None else ()
        view = next((v for v in views if v.camera == camera), None)
        if image is None and view is None:
            return None
        labels = None
        if view is not None and latest is not None:  # track ids, user ids, the navigator's colour
            result = latest.result
            tracked = next((t for t in result.views if t.camera == camera), None)
            labels = person_labels(view, tracked, result.people3d, result.navigator)
        data = render_snapshot(image, view, self.long_side, labels=labels)
        self._cached[camera] = (now, data)
        return data
