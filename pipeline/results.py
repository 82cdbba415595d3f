"""Per-frame results and their JSON Lines form (SPEC.md "Per-frame results")."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, overload

import numpy as np

from pipeline.head.tracker import HeadEstimate
from pipeline.navigation.navigators import NavigationFrame
from pipeline.recognition.types import ActionEstimate
from pipeline.tracking.types import TrackedView
from pipeline.triangulation.types import Person3D


@dataclass(frozen=True, slots=True)
class FrameResult:
    """Everything the pipeline knows about one multi-view frame.

    frame_index: index of the multi-view frame.
    timestamp_s: capture time of the frame, seconds.
    views: per-camera tracked people (may be empty).
    people3d: 3D skeletons with user ids.
    navigator: user_id of the primary navigator, or None.
    action: the navigator's command, or None when there is no navigator.
    heads: the navigators' head estimates (issue 20; empty when unknown or turned off).
    navigation: each navigating person's command and the group's (issue 20), None when the
        navigation stage does not run (no 3D).
    """

    frame_index: int
    timestamp_s: float
    views: tuple[TrackedView, ...] = ()
    people3d: tuple[Person3D, ...] = ()
    navigator: int | None = None
    action: ActionEstimate | None = None
    heads: tuple[HeadEstimate, ...] = ()
    extra: dict[str, Any] = field(default_factory=dict)
    navigation: NavigationFrame | None = None


def _num(x: float, nd: int = 4) -> float | None:
    return None if x is None or not math.isfinite(float(x)) else round(float(x), nd)


def view_record(view: TrackedView) -> dict[str, Any]:
    people = []
    for i, tid in enumerate(view.track_ids.tolist()):
        kp = view.keypoints_xy[i]
        sc = view.keypoint_scores[i]
        people.append({
            "track_id": int(tid),
            "bbox": [_num(v, 2) for v in view.boxes_xyxy[i].tolist()],
            "keypoints": [[_num(kp[j, 0], 2), _num(kp[j, 1], 2), _num(sc[j], 3)] for j in range(len(kp))],
        })
    return {"camera": view.camera, "people": people}


def person_record(p: Person3D) -> dict[str, Any]:
    joints: list[list[float | None] | None] = []
    for j in range(p.joints_m.shape[0]):
        if p.joint_valid[j] and np.all(np.isfinite(p.joints_m[j])):
            joints.append([_num(v, 4) for v in p.joints_m[j].tolist()])
        else:
            joints.append(None)
    return {"user_id": int(p.user_id), "joints": joints, "reproj_px": _num(p.reproj_px, 3)}


@overload
def action_record(a: ActionEstimate) -> dict[str, Any]: ...


@overload
def action_record(a: None) -> None: ...


def action_record(a: ActionEstimate | None) -> dict[str, Any] | None:
    if a is None:
        return None
    out: dict[str, Any] = {
        "label": a.label,
        "probs": {k: _num(v, 4) for k, v in a.probs.items()},
        "yaw_deg": _num(a.yaw_deg, 2),
        "speed_mps": _num(a.speed_mps, 3),
    }
    if a.steps is not None:  # the step evidence and the gate's verdict (the dashboard's step strip)
        out["steps"] = a.steps.to_dict() | {"gate": None if a.gate is None else a.gate.to_dict()}
    return out


def frame_record(result: FrameResult) -> dict[str, Any]:
    """The JSON object of one line of the per-frame results file."""
    return {
        "frame": int(result.frame_index),
        "t": _num(result.timestamp_s, 6),
        "views": [view_record(v) for v in result.views],
        "people3d": [person_record(p) for p in result.people3d],
        "navigator": result.navigator,
        "action": action_record(result.action),
    }


class ResultsWriter:
    """Writes FrameResults as JSON Lines, one object per line, flushed per frame."""

    def __init__(self, path: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        self._f: IO[str] = path.open("w", encoding="utf-8")

    def write(self, result: FrameResult) -> None:
        self._f.write(json.dumps(frame_record(result), separators=(",", ":")) + "\n")
        self._f.flush()

    def close(self) -> None:
        self._f.close()

    def __enter__(self) -> ResultsWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
