"""The viser 3D view: stable scene names, handles updated in place, the port free after shutdown."""

from __future__ import annotations

import math
import socket
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from app.viewer import Viewer, body_yaw_deg, bone_segments, facing_arrow, joints_array, user_color
from pipeline.skeleton import BONES, J
from tests.app.conftest import make_settings


def standing_person(x: float, y: float) -> list[list[float] | None]:
    """A crude upright skeleton at (x, y): joints at plausible heights, left side at -x."""
    heights = {
        "nose": 1.65,
        "l_eye": 1.68,
        "r_eye": 1.68,
        "l_ear": 1.66,
        "r_ear": 1.66,
        "l_shoulder": 1.45,
        "r_shoulder": 1.45,
        "l_elbow": 1.15,
        "r_elbow": 1.15,
        "l_wrist": 0.9,
        "r_wrist": 0.9,
        "l_hip": 0.95,
        "r_hip": 0.95,
        "l_knee": 0.5,
        "r_knee": 0.5,
        "l_ankle": 0.08,
        "r_ankle": 0.08,
    }
    out: list[list[float] | None] = []
    for name, z in heights.items():
        dx = -0.15 if name.startswith("l_") else 0.15 if name.startswith("r_") else 0.0
        out.append([x + dx, y, z])
    return out


def port_is_free(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def test_pure_helpers() -> None:
    person = standing_person(0.0, 0.0)
    person[J["l_ankle"]] = None
    joints = joints_array(person)
    assert joints.shape == (17, 3) and np.isnan(joints[J["l_ankle"]]).all()
    segs = bone_segments(joints)
    assert len(segs) == len(BONES) - 1, "the bone to the unknown ankle is left out"
    # yaw 0 faces +Y; 90 faces -X (counter-clockwise seen from above)
    for yaw, direction in ((0.0, (0.0, 1.0)), (90.0, (-1.0, 0.0)), (-90.0, (1.0, 0.0))):
        arrow = facing_arrow(joints, yaw, length_m=1.0)
        assert arrow is not None
        d = arrow[0, 1, :2] - arrow[0, 0, :2]
        assert np.allclose(d, direction, atol=1e-6), (yaw, d)
    assert facing_arrow(joints, math.nan) is None
    # standing_person has its left side at -x: it faces +Y (yaw 0); mirrored, it faces -Y (yaw 180)
    assert body_yaw_deg(joints_array(standing_person(0, 0))) == pytest.approx(0.0, abs=1e-6)
    mirrored = joints_array(standing_person(0, 0)) * np.array([-1.0, 1.0, 1.0], dtype=np.float32)
    assert abs(body_yaw_deg(mirrored)) == pytest.approx(180.0, abs=1e-6)
    assert len({user_color(i) for i in range(12)}) == 12


def test_scene_updates_in_place_and_port_is_free_after_stop(tmp_path: Path) -> None:
    settings = make_settings(tmp_path, viser=True)
    port = settings.server.viser_port
    viewer = Viewer.start(settings)
    try:
        assert viewer.port == port
        assert not port_is_free(port)
        assert set(viewer.cameras) == {"cam01", "cam02", "cam03", "cam04"}, "the simulator's default cameras"
        snap: dict[str, Any] = {
            "navigator": 3,
            "action": {"label": "forward", "yaw_deg": 30.0},
            "extra": {
                "people3d": [
                    {"user_id": 3, "joints": standing_person(0, 0)},
                    {"user_id": 5, "joints": standing_person(1, 1)},
                ]
            },
        }
        viewer.update(snap)
        handles = {uid: (p.joints, p.bones) for uid, p in viewer.people.items()}
        assert set(handles) == {3, 5}
        assert handles[3][0].name == "/people/3/joints" and handles[5][1].name == "/people/5/bones"
        assert viewer.arrow is not None and viewer.arrow.visible
        assert viewer.people[3].label.text == "user 3 · navigator" and viewer.people[5].label.text == "user 5"
        assert viewer.people[3].label.position[2] > 1.8, "the label floats over the head"
        snap["people"] = [{"user_id": 3, "command": {"label": "left", "confidence": 0.874}},
                          {"user_id": 5, "command": {"label": "forward", "confidence": 0.6}}]
        viewer.update(snap)  # each mode: every skeleton is labelled with its own command
        assert viewer.people[3].label.text == "user 3 · navigator · left 87 %"
        assert viewer.people[5].label.text == "user 5 · forward 60 %"
        moved = standing_person(0.5, 0)
        snap["extra"]["people3d"] = [{"user_id": 3, "joints": moved}]
        viewer.update(snap)
        assert set(viewer.people) == {3}, "user 5 left: its handles are removed"
        assert viewer.people[3].joints is handles[3][0], "the same handle is updated in place"
        assert np.allclose(
            viewer.people[3].joints.points[:, 0].mean(), np.mean([j[0] for j in moved]), atol=1e-2
        )
        snap["action"] = None  # no recogniser: the arrow follows the body's own facing
        viewer.update(snap)
        assert viewer.arrow.visible
        snap["navigator"] = None
        viewer.update(snap)
        assert not viewer.arrow.visible
    finally:
        viewer.stop()
    assert port_is_free(port), "the viser port must be free again after stop()"


@pytest.mark.slow
def test_app_lifespan_frees_the_viser_port(tmp_path: Path) -> None:
    from fastapi.testclient import TestClient

    from app.main import create_app

    settings = make_settings(tmp_path, viser=True)
    with TestClient(create_app(settings, pipeline_factory=None)) as c:
        assert c.get("/api/v1/info").json()["viser_port"] == settings.server.viser_port
        assert not port_is_free(settings.server.viser_port)
    assert port_is_free(settings.server.viser_port)


def test_a_pushed_status_is_drawn_from_its_arrays_as_its_json_form_is(tmp_path: Path) -> None:
    """The live view takes the pipeline's typed status as it comes (issue 16 item 4); a replay's
    JSON frame of the same people draws the same scene."""
    from pipeline.runtime.status import ActionStatus, PersonStatus, PipelineStatus, Skeleton

    joints = {3: joints_array(standing_person(0, 0)), 5: joints_array(standing_person(1, 1))}
    joints[5][J["l_ankle"]] = np.nan
    status = PipelineStatus(
        "running", navigator=3, action=ActionStatus("forward", 0.9, {"forward": 0.9}, 30.0, 0.5),
        people=(PersonStatus(3, (0.0, 0.0, 0.95), 1.0, True, True,
                             ActionStatus("left", 0.874, {"left": 0.874}, 10.0, 0.4)),
                PersonStatus(5, (1.0, 1.0, 0.95), 1.0)),
        people3d=tuple(Skeleton(uid, j.astype(np.float64), 1.0) for uid, j in joints.items()))
    settings = make_settings(tmp_path, viser=True)
    viewer = Viewer.start(settings)
    try:
        drawn: list[dict[Any, Any]] = []
        for typed in (True, False):
            if typed:
                viewer.on_status(status, status.to_json())
            else:
                viewer.update(status.to_json())
            drawn.append({uid: (p.label.text, np.asarray(p.joints.points).round(4).tolist(),
                                np.asarray(p.bones.points).round(4).tolist())
                          for uid, p in viewer.people.items()})
            drawn[-1]["arrow"] = np.asarray(viewer.arrow.points).round(4).tolist()
        assert drawn[0] == drawn[1], "the typed status and its JSON draw the same scene"
        assert drawn[0][3][0] == "user 3 · navigator · left 87 %" and drawn[0][5][0] == "user 5"
        assert len(drawn[0][5][2]) == len(BONES) - 1, "the bone to the unknown ankle is left out"
    finally:
        viewer.stop()
