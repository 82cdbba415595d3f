"""Camera snapshots label each person with their track id (and user id) in the dashboard's colours."""

from __future__ import annotations

import cv2
import numpy as np

from pipeline.pose.types import ViewDetections
from pipeline.runtime.snapshot import NAVIGATOR_BGR, OTHER_BGR, PersonLabel, person_labels, render_snapshot
from pipeline.tracking.types import TrackedView
from pipeline.triangulation.types import Person3D


def view_of_two() -> ViewDetections:
    kp = np.zeros((2, 17, 2), np.float32)
    for p, x0 in enumerate((100.0, 400.0)):
        kp[p, :, 0] = x0 + np.linspace(0, 60, 17)
        kp[p, :, 1] = np.linspace(80, 380, 17)
    boxes = np.array([[90, 70, 170, 390], [390, 70, 470, 390]], np.float32)
    return ViewDetections(
        "cam01", 0, 0.0, (640, 480), boxes, np.ones(2, np.float32), kp, np.ones((2, 17), np.float32)
    )


def test_labels_name_track_and_user_and_mark_the_navigator() -> None:
    view = view_of_two()
    tracked = TrackedView(view, np.array([7, 9]), np.array([1, 0]))
    nav = Person3D(3, np.zeros((17, 3)), np.ones(17, bool), 1.0, views=(("cam01", 7), ("cam02", 2)))
    labels = person_labels(view, tracked, [nav], navigator=3)
    assert labels == [PersonLabel("track 9"), PersonLabel("track 7, user 3", navigator=True)]
    assert person_labels(view, None, [nav], 3) == [PersonLabel(""), PersonLabel("")], "untracked"


def test_the_navigator_is_drawn_in_the_legend_colour() -> None:
    view = view_of_two()
    labels = [PersonLabel("track 9"), PersonLabel("track 7, user 3", navigator=True)]
    img = cv2.imdecode(
        np.frombuffer(render_snapshot(None, view, 640, labels=labels, quality=100), np.uint8), 1
    )

    def near(colour: tuple[int, int, int], region: np.ndarray) -> int:
        return int((np.abs(region.astype(int) - np.array(colour)).sum(axis=2) < 60).sum())

    left, right = img[:, :300], img[:, 300:]
    assert near(NAVIGATOR_BGR, right) > 200 and near(NAVIGATOR_BGR, left) == 0, "the navigator is orange"
    assert near(OTHER_BGR, left) > 200, "the others in the 'others' colour"
