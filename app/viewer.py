"""The 3D view: one viser server showing the CAVE, the cameras and the people tracked now.

Scene names are stable (``/cave/...``, ``/cameras/{name}``, ``/people/{user_id}/joints``,
``/people/{user_id}/bones``, ``/navigator/arrow``); handles are kept and updated in place,
each status's updates inside ``server.atomic()``. Created and stopped by the app's lifespan.
"""

from __future__ import annotations

import colorsys
import contextlib
import io
import logging
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from app.core.config import Settings
from pipeline.camera import Camera
from pipeline.cave import CaveGeometry
from pipeline.runtime.status import PipelineStatus
from pipeline.skeleton import BONES, J

log = logging.getLogger(__name__)

F32 = NDArray[np.float32]

NAVIGATOR_COLOR = (255, 140, 0)
#: where the viser server listens; the app proxies it to the network (app/api/viewer_proxy.py)
VISER_HOST = "127.0.0.1"
#: How long a replayed take's frame stays in the view without another (then: the live people again).
REPLAY_HOLD_S = 120.0


def user_color(user_id: int) -> tuple[int, int, int]:
    """A stable, distinct colour per user id (golden-ratio hues, never the navigator's orange)."""
    hue = (0.55 + 0.618034 * user_id) % 1.0
    if abs(hue - 0.08) < 0.05:
        hue = (hue + 0.1) % 1.0
    r, g, b = colorsys.hsv_to_rgb(hue, 0.65, 0.95)
    return int(r * 255), int(g * 255), int(b * 255)


def joints_array(joints: Sequence[Sequence[float] | None]) -> F32:
    """17 joints ``[x, y, z]`` or None -> (17, 3) float32 with NaN where unknown."""
    out = np.full((len(joints), 3), np.nan, dtype=np.float32)
    for i, j in enumerate(joints):
        if j is not None and len(j) == 3 and all(v is not None for v in j):
            out[i] = np.asarray(j, dtype=np.float32)
    return out


def bone_segments(joints: F32) -> F32:
    """(B, 2, 3) segments of the skeleton's bones whose two ends are known."""
    segs = [
        (joints[a], joints[b])
        for a, b in BONES
        if np.all(np.isfinite(joints[a])) and np.all(np.isfinite(joints[b]))
    ]
    return np.asarray(segs, dtype=np.float32).reshape(-1, 2, 3)


def facing_arrow(joints: F32, yaw_deg: float, length_m: float = 0.6) -> F32 | None:
    """(3, 2, 3) segments of an arrow on the floor under the hips, pointing along ``yaw_deg``.

    yaw 0 = facing +Y, positive counter-clockwise seen from above (SPEC.md).
    """
    hips = joints[[J["l_hip"], J["r_hip"]]]
    hips = hips[np.all(np.isfinite(hips), axis=1)]
    if len(hips) == 0 or not math.isfinite(yaw_deg):
        return None
    base = hips.mean(axis=0)
    base[2] = 0.02
    yaw = math.radians(yaw_deg)
    d = np.array([-math.sin(yaw), math.cos(yaw), 0.0], dtype=np.float32)
    side = np.array([d[1], -d[0], 0.0], dtype=np.float32)
    tip = base + d * length_m
    head = 0.15 * length_m
    return np.asarray(
        [[base, tip], [tip, tip - d * head + side * head * 0.6], [tip, tip - d * head - side * head * 0.6]],
        dtype=np.float32,
    )


def body_yaw_deg(joints: F32) -> float:
    """Facing direction from the hips (else the shoulders): yaw 0 = +Y, counter-clockwise positive."""
    for left, right in (("l_hip", "r_hip"), ("l_shoulder", "r_shoulder")):
        a, b = joints[J[left]], joints[J[right]]
        if np.all(np.isfinite(a)) and np.all(np.isfinite(b)):
            across = b[:2] - a[:2]  # left -> right
            if float(np.hypot(*across)) > 1e-3:
                fx, fy = -across[1], across[0]  # 90 degrees counter-clockwise: the way the body faces
                return math.degrees(math.atan2(-fx, fy))
    return math.nan


def wall_mesh(cave: CaveGeometry) -> tuple[F32, NDArray[np.int32]]:
    verts = np.concatenate([w.corners_m for w in cave.walls]).astype(np.float32)
    faces = []
    for k in range(len(cave.walls)):
        o = 4 * k
        faces += [[o, o + 1, o + 2], [o, o + 2, o + 3]]
    return verts, np.asarray(faces, dtype=np.int32)


def wall_outlines(cave: CaveGeometry) -> F32:
    segs = [[w.corners_m[i], w.corners_m[(i + 1) % 4]] for w in cave.walls for i in range(4)]
    return np.asarray(segs, dtype=np.float32)


def camera_pose(cam: Camera) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(wxyz quaternion, position) of the camera-to-world transform (OpenCV camera axes)."""
    import viser.transforms as vtf

    r_cw = cam.R.T
    position = -r_cw @ cam.t
    return np.asarray(vtf.SO3.from_matrix(r_cw).wxyz), position


@dataclass(slots=True)
class _Person:
    joints: Any
    bones: Any
    label: Any = None  # "user 3" (+ "navigator") over the head


@dataclass(frozen=True, slots=True)
class Scene:
    """What the view draws of one status: each person's skeleton ((17, 3) float32, NaN where
    unknown), the navigator, the yaw of its arrow (None: the body's own facing) and each person's
    own command (label, confidence)."""

    skeletons: tuple[tuple[int, F32], ...]
    navigator: int | None
    yaw_deg: float | None
    commands: dict[int, tuple[str, float]]

    @classmethod
    def of_status(cls, status: PipelineStatus) -> Scene:
        """A live status, as the pipeline pushed it."""
        return cls(tuple((s.user_id, s.joints_m.astype(np.float32)) for s in status.people3d),
                   status.navigator, status.action.yaw_deg if status.action is not None else None,
                   {p.user_id: (p.command.label, p.command.confidence) for p in status.people
                    if p.command is not None})

    @classmethod
    def of_snapshot(cls, snapshot: Mapping[str, Any]) -> Scene:
        """A status's JSON form, or a recorded frame in it (a take's replay)."""
        skeletons = []
        for p in (snapshot.get("extra") or {}).get("people3d") or []:
            joints = joints_array(p.get("joints") or p.get("joints_m") or [])
            if joints.shape == (17, 3):
                skeletons.append((int(p["user_id"]), joints))
        yaw = (snapshot.get("action") or {}).get("yaw_deg")
        commands = {}
        for p in snapshot.get("people") or []:
            c = p.get("command") if isinstance(p, Mapping) and p.get("user_id") is not None else None
            if c and c.get("label"):
                commands[int(p["user_id"])] = (str(c["label"]), float(c.get("confidence") or 0.0))
        return cls(tuple(skeletons), snapshot.get("navigator"), None if yaw is None else float(yaw), commands)


def label_text(user_id: int, navigator: int | None, command: tuple[str, float] | None = None) -> str:
    """``user 3 · navigator · forward 87 %``: the id, the navigator, and the person's own command
    (label, confidence; each and group modes; in single mode the navigator's)."""
    text = f"user {user_id}" + (" · navigator" if user_id == navigator else "")
    if command is not None:
        text += f" · {command[0]} {100 * command[1]:.0f} %"
    return text


def label_position(joints: F32) -> NDArray[np.float32] | None:
    """30 cm over the highest known joint (the head), or None when no joint is known."""
    known = joints[np.all(np.isfinite(joints), axis=1)]
    if len(known) == 0:
        return None
    top = known[np.argmax(known[:, 2])].copy()
    top[2] += 0.3
    return top


@dataclass(slots=True)
class Viewer:
    """The one ViserServer of the app and the handles of its scene."""

    server: Any
    cave: CaveGeometry
    people: dict[int, _Person] = field(default_factory=dict)
    cameras: dict[str, Any] = field(default_factory=dict)
    arrow: Any = None
    replay_until: float = 0.0  # time.monotonic() until which a take's frame is shown, not the live one

    @classmethod
    def start(cls, settings: Settings, cameras: Sequence[Camera] | None = None) -> Viewer:
        import viser

        with contextlib.redirect_stdout(io.StringIO()):  # viser prints a banner whatever verbose says
            # loopback only, whatever server.host is: the network reaches the view through the app's
            # /viewer/ proxy, behind the operator token (app/api/viewer_proxy.py, issue 15 D8)
            server = viser.ViserServer(host=VISER_HOST, port=settings.server.viser_port, verbose=False)
        viewer = cls(server=server, cave=settings.cave.geometry())
        viewer._build_static()
        viewer.show_cameras(cameras if cameras is not None else _default_cameras(settings))
        log.info("3D view on http://%s:%d (and at /viewer/ of the app)", VISER_HOST, viewer.port)
        return viewer

    @property
    def port(self) -> int:
        return int(self.server.get_port())

    def _build_static(self) -> None:
        scene = self.server.scene
        scene.set_up_direction("+z")
        hx, hy = self.cave.floor_half_size_m
        scene.add_grid(
            "/cave/floor", width=2 * hx, height=2 * hy, plane="xy", cell_size=0.25, section_size=1.0
        )
        verts, faces = wall_mesh(self.cave)
        scene.add_mesh_simple("/cave/walls", verts, faces, color=(120, 160, 220), opacity=0.12, side="double")
        scene.add_line_segments(
            "/cave/outlines", wall_outlines(self.cave), colors=(70, 90, 140), thickness=0.01
        )
        scene.add_frame("/cave/origin", axes_length=0.3, axes_radius=0.01)
        for wall in self.cave.walls:  # each wall's name at the middle of its top edge
            corners = np.asarray(wall.corners_m, dtype=np.float32)
            top = corners[np.argsort(corners[:, 2])[-2:]].mean(axis=0)
            scene.add_label(f"/cave/labels/{wall.name}", f"{wall.name} wall", position=top,
                            anchor="bottom-center")  # fmt: skip

    def show_cameras(self, cameras: Sequence[Camera]) -> None:
        """Camera frusta at the calibrated poses (replacing those shown before)."""
        with self.server.atomic():
            for name in set(self.cameras) - {c.name for c in cameras}:
                self.cameras.pop(name).remove()
            for cam in cameras:
                w, h = cam.image_size
                fov = 2.0 * math.atan2(h / 2.0, float(cam.K[1, 1]))
                wxyz, pos = camera_pose(cam)
                handle = self.cameras.get(cam.name)
                if handle is None:
                    self.cameras[cam.name] = self.server.scene.add_camera_frustum(
                        f"/cameras/{cam.name}",
                        fov=fov,
                        aspect=w / h,
                        scale=0.25,
                        thickness=0.01,
                        color=(40, 40, 40),
                        wxyz=wxyz,
                        position=pos,
                    )
                else:
                    handle.fov, handle.aspect, handle.wxyz, handle.position = fov, w / h, wxyz, pos

    def on_status(self, status: PipelineStatus, message: Mapping[str, Any]) -> None:
        """Show a live status as the pipeline pushed it: its skeletons' joints, the navigator's arrow."""
        self.show(Scene.of_status(status))

    def update(self, snapshot: Mapping[str, Any]) -> None:
        """Show the skeletons of a status's JSON form (``extra.people3d``) and the navigator's arrow."""
        self.show(Scene.of_snapshot(snapshot))

    def show(self, scene: Scene) -> None:
        """The live people; ignored while a take replays (:meth:`show_replay`)."""
        if self.replay_until:
            if time.monotonic() < self.replay_until:
                return
            self.replay_until = 0.0  # the replay was left: back to the live people
        self._draw(scene)

    def show_replay(self, snapshot: Mapping[str, Any] | None, hold_s: float = REPLAY_HOLD_S) -> None:
        """A recorded frame (the same shape as a live status's JSON) in place of the live people, for
        ``hold_s`` seconds unless another comes; None: back to live at the next update."""
        if snapshot is None:
            self.replay_until = 0.0
            return
        self.replay_until = time.monotonic() + hold_s
        self._draw(Scene.of_snapshot(snapshot))

    def _draw(self, view: Scene) -> None:
        navigator, commands = view.navigator, view.commands
        scene = self.server.scene
        seen: set[int] = set()
        nav_joints: F32 | None = None
        with self.server.atomic():
            for uid, joints in view.skeletons:
                seen.add(uid)
                color = NAVIGATOR_COLOR if uid == navigator else user_color(uid)
                valid = joints[np.all(np.isfinite(joints), axis=1)]
                segs = bone_segments(joints)
                person = self.people.get(uid)
                if person is None:
                    person = _Person(
                        joints=scene.add_point_cloud(
                            f"/people/{uid}/joints",
                            valid,
                            colors=color,
                            point_size=0.05,
                            point_shape="circle",
                        ),
                        bones=scene.add_line_segments(
                            f"/people/{uid}/bones", segs, colors=color, thickness=0.02
                        ),
                    )
                    self.people[uid] = person
                else:
                    person.joints.points = valid
                    person.joints.colors = np.tile(np.asarray(color, np.uint8), (len(valid), 1))
                    person.bones.points = segs
                    person.bones.colors = np.tile(np.asarray(color, np.uint8), (len(segs), 2, 1))
                head = label_position(joints)
                if person.label is None and head is not None:
                    person.label = scene.add_label(
                        f"/people/{uid}/label",
                        label_text(uid, navigator, commands.get(uid)),
                        position=head,
                        anchor="bottom-center",
                    )
                elif person.label is not None:
                    person.label.text = label_text(uid, navigator, commands.get(uid))
                    if head is not None:
                        person.label.position = head
                if uid == navigator:
                    nav_joints = joints
            for uid in set(self.people) - seen:
                gone = self.people.pop(uid)
                gone.joints.remove()
                gone.bones.remove()
                if gone.label is not None:
                    gone.label.remove()
            arrow = None
            if nav_joints is not None:
                yaw = view.yaw_deg  # the recogniser's smoothed yaw, else the body's own
                arrow = facing_arrow(nav_joints, yaw if yaw is not None else body_yaw_deg(nav_joints))
            if arrow is None:
                if self.arrow is not None:
                    self.arrow.visible = False
            elif self.arrow is None:
                self.arrow = scene.add_line_segments(
                    "/navigator/arrow", arrow, colors=NAVIGATOR_COLOR, thickness=0.03
                )
            else:
                self.arrow.points = arrow
                self.arrow.visible = True

    def stop(self) -> None:
        """Stop the server and free its port."""
        self.server.stop()


def _default_cameras(settings: Settings) -> list[Camera]:
    """The simulator's default cameras, shown until a calibration is active."""
    try:
        from pipeline.sim.scene import default_cameras
    except ImportError:
        return []
    try:
        return list(default_cameras(settings.cave.geometry(), settings.sim.camera_preset))
    except Exception:
        log.exception("could not build the simulator's default cameras")
        return []
