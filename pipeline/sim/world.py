"""A simulated CAVE with people in it: a navigator plus bystanders, seen by virtual cameras.

:class:`SimWorld` steps frame by frame (``step()``) or runs as an iterator, as fast as
possible or in real time. The navigator plays a :class:`MotionScript` (then random
routines) or random routines from the start; bystanders walk between random spots on the
floor, stand, gesture and turn, and so sometimes stand between a camera and the navigator.
Motion is generated in chunks and joined with a short cross-fade, so a world can run forever.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.camera import Camera
from pipeline.cave import CaveGeometry
from pipeline.errors import InputError
from pipeline.pose.types import ViewDetections
from pipeline.recognition.types import ActionEstimate
from pipeline.results import FrameResult
from pipeline.sim.body import BodyParams, MotionStyle, body_from_height, sample_body, sample_style
from pipeline.sim.config import STEPPER_HOMES_M, SimConfig
from pipeline.sim.motion import UserMotion, simulate_user, smoothstep, wrap_deg
from pipeline.sim.scene import default_cameras
from pipeline.sim.script import MotionScript, Segment, random_script
from pipeline.sim.views import observe_with_ids
from pipeline.skeleton import J
from pipeline.tracking.types import TrackedView
from pipeline.triangulation.types import Person3D

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

NAVIGATOR = "navigator"
_CROSSFADE_S = 0.3
WALL_CLEARANCE_M = 0.45  # bystanders keep about half a metre from the screens


@dataclass(frozen=True, slots=True)
class SimFrame:
    """One multi-view frame of the simulated world.

    truth: (name, (17, 3) joints in metres) per person; the navigator first.
    label / yaw_deg / speed_mps / tag / contacts: the navigator's ground truth (tag: what the
    navigator does, "" for nothing special; contacts: feet planted [left, right]).
    views: what each camera's pose detector reports.
    view_people: per view, for each detection, the index into ``truth`` (-1 = false detection).
    """

    frame_index: int
    timestamp_s: float
    truth: tuple[tuple[str, F64], ...]
    label: str
    yaw_deg: float
    speed_mps: float
    views: tuple[ViewDetections, ...]
    view_people: tuple[I64, ...]
    tag: str = ""
    contacts: tuple[bool, bool] = (True, True)
    labels: tuple[str, ...] = ()

    @property
    def navigator_joints(self) -> F64:
        return self.truth[0][1]

    def to_result(self) -> FrameResult:
        """This frame as a per-frame result of the pipeline, from the ground truth: the views
        tracked with the true person index as track id (0 = the navigator; false detections
        stay untracked), the true 3D people (user_id = person index) and the navigator's action."""
        views = []
        for view, ids in zip(self.views, self.view_people, strict=True):
            keep = np.flatnonzero(ids >= 0)
            views.append(TrackedView(view, ids[keep], keep))
        people = tuple(
            Person3D(i, joints, np.ones(len(joints), dtype=bool), 0.0)
            for i, (_, joints) in enumerate(self.truth)
        )
        action = ActionEstimate(self.label, {self.label: 1.0}, self.yaw_deg, self.speed_mps)
        return FrameResult(self.frame_index, self.timestamp_s, tuple(views), people, 0, action)


class _Actor:
    """One person: a body, a style and an endless stream of motion chunks."""

    def __init__(
        self, name: str, body: BodyParams, style: MotionStyle, fps: float, rng: np.random.Generator
    ) -> None:
        self.name = name
        self.body = body
        self.style = style
        self.fps = fps
        self.rng = rng
        self.motion: UserMotion | None = None
        self.cursor = 0
        self.previous: F64 | None = None  # last pose of the previous chunk, for the cross-fade

    def next_script(self) -> MotionScript:
        raise NotImplementedError

    def _load(self) -> None:
        feet = None
        if self.motion is not None:
            self.previous = self.motion.joints_m[-1].copy()
            last = self.motion.joints_m[-1]
            feet = (last[J["l_ankle"], :2].copy(), last[J["r_ankle"], :2].copy())
        script = self.next_script()
        seed = int(self.rng.integers(2**31))
        if feet is not None and np.linalg.norm(0.5 * (feet[0] + feet[1]) - script.start_xy_m) > 0.3:
            feet = None  # a script of its own somewhere else (the navigator's own routine)
        self.motion = simulate_user(
            script, self.body, fps=self.fps, seed=seed, style=self.style, start_feet_xy_m=feet
        )  # a continuing chunk starts on the feet the last one ended on
        self.cursor = 0

    def end_state(self) -> tuple[tuple[float, float], float]:
        if self.motion is None:
            return (0.0, 0.0), 0.0
        xy = self.motion.root_xy_m[-1]
        return (float(xy[0]), float(xy[1])), float(self.motion.yaw_deg[-1])

    def step(self) -> tuple[F64, str, float, float, str, tuple[bool, bool]]:
        if self.motion is None or self.cursor >= len(self.motion):
            self._load()
        m = self.motion
        assert m is not None  # for mypy; _load always sets it
        i = self.cursor
        self.cursor += 1
        joints = m.joints_m[i]
        n_fade = max(1, round(_CROSSFADE_S * self.fps))
        if self.previous is not None and i < n_fade:
            w = float(smoothstep(np.array((i + 1) / n_fade)))
            joints = (1.0 - w) * self.previous + w * joints
        feet = (bool(m.contacts[i, 0]), bool(m.contacts[i, 1]))
        return joints, m.labels[i], float(m.yaw_deg[i]), float(m.speed_mps[i]), m.tags[i], feet


class _Navigator(_Actor):
    def __init__(
        self,
        body: BodyParams,
        style: MotionStyle,
        fps: float,
        rng: np.random.Generator,
        *,
        script: MotionScript | None,
        repeat: bool,
        chunk_s: float,
        home_xy: tuple[float, float],
        name: str = NAVIGATOR,
    ) -> None:
        super().__init__(name, body, style, fps, rng)
        self.script = script
        self.repeat = repeat
        self.chunk_s = chunk_s
        self.home = np.asarray(home_xy, dtype=np.float64)
        self.played = 0

    def next_script(self) -> MotionScript:
        xy, yaw = self.end_state() if self.motion is not None else ((0.0, 0.0), 0.0)
        self.played += 1
        if self.script is not None and (self.played == 1 or self.repeat):
            if self.played == 1:
                return self.script
            return MotionScript(self.script.segments, start_xy_m=xy, start_yaw_deg=yaw)
        if self.motion is None:
            xy = (float(self.home[0]), float(self.home[1]))
            yaw = float(self.rng.uniform(-180, 180))
        offset = self.home - np.asarray(xy)
        if np.linalg.norm(offset) > 0.6:  # drifted off the centre: turn and walk back first
            return _walk_to(xy, yaw, self.home, self.rng, then=random_script(self.rng, self.chunk_s).segments)
        return random_script(self.rng, self.chunk_s, start_xy_m=xy, start_yaw_deg=yaw)


class _Bystander(_Actor):
    def __init__(
        self,
        name: str,
        body: BodyParams,
        style: MotionStyle,
        fps: float,
        rng: np.random.Generator,
        *,
        floor_half: tuple[float, float],
        keep_clear: F64,
    ) -> None:
        super().__init__(name, body, style, fps, rng)
        self.half = np.asarray(floor_half, dtype=np.float64) - WALL_CLEARANCE_M
        self.keep_clear = keep_clear
        self.start = self._spot()

    def _spot(self) -> F64:
        for _ in range(100):
            p = self.rng.uniform(-self.half, self.half)
            if np.linalg.norm(p - self.keep_clear) > 0.8:
                return p
        return np.asarray(self.half, dtype=np.float64)

    def _route(self, start: F64, target: F64) -> list[F64]:
        """Waypoints to ``target`` that pass the navigator at arm's length rather than through them."""
        d = target - start
        length = float(np.linalg.norm(d))
        if length < 1e-6:
            return [target]
        along = float(np.clip((self.keep_clear - start) @ d / length**2, 0.0, 1.0))
        closest = start + along * d
        gap = self.keep_clear - closest
        if np.linalg.norm(gap) >= 0.6:
            return [target]
        side = np.array([-d[1], d[0]]) / length
        if float(side @ gap) > 0:  # go round on the far side from the navigator
            side = -side
        detour = np.clip(self.keep_clear + 0.8 * side, -self.half, self.half)
        return [detour, target]

    def next_script(self) -> MotionScript:
        if self.motion is None:
            xy = (float(self.start[0]), float(self.start[1]))
            yaw = float(self.rng.uniform(-180, 180))
        else:
            xy, yaw = self.end_state()
        # One stand-and-walk per chunk, so that each walk starts from where the last really ended.
        segments: list[Segment] = [Segment("still", float(self.rng.uniform(2.0, 8.0)))]
        pos, heading = np.asarray(xy), yaw
        for waypoint in self._route(pos, self._spot()):
            script = _walk_to((float(pos[0]), float(pos[1])), heading, waypoint, self.rng, then=())
            segments.extend(script.segments)
            pos = waypoint
            heading = heading + sum(s.yaw_change_deg for s in script.segments)
        return MotionScript(tuple(segments), start_xy_m=xy, start_yaw_deg=yaw)


def _walk_to(
    xy: tuple[float, float], yaw: float, target: F64, rng: np.random.Generator, then: tuple[Segment, ...]
) -> MotionScript:
    """Turn towards ``target``, walk there at a normal pace, then play ``then``."""
    d = np.asarray(target, dtype=np.float64) - np.asarray(xy, dtype=np.float64)
    dist = float(np.linalg.norm(d))
    want = math.degrees(math.atan2(-d[0], d[1]))
    turn = float(wrap_deg(np.array(want - yaw)))
    speed = float(rng.uniform(0.5, 0.9))
    segs = [Segment("turn", max(0.4, abs(turn) / 150.0), turn_deg=turn)]
    if dist > 0.05:  # a walk covers travel_mps x its duration, first lift-off to last touch-down
        segs.append(Segment("forward", max(0.3, dist / speed), travel_mps=dist / max(0.3, dist / speed)))
    return MotionScript(tuple(segs) + tuple(then), start_xy_m=xy, start_yaw_deg=yaw)


class SimWorld:
    """Virtual cameras around a navigator and bystanders; each ``step()`` is one multi-view frame."""

    def __init__(
        self,
        cave: CaveGeometry,
        cameras: list[Camera],
        config: SimConfig,
        script: MotionScript | None = None,
        steppers: Sequence[MotionScript] = (),
    ) -> None:
        """steppers: the routines of further stepping people (``navigator2``, ...), each starting
        where its script does; without them ``config.people - 1`` step random routines."""
        if not cameras:
            raise InputError("a simulated world needs at least one camera")
        self.cave = cave
        self.cameras = list(cameras)
        self.config = config
        self._rng_views, rng_nav, *rng_people = (
            np.random.default_rng(s) for s in np.random.SeedSequence(config.seed).spawn(2 + config.bystanders)
        )
        n_steppers = len(steppers) if steppers else int(config.people) - 1
        rng_steppers = [np.random.default_rng(s) for s in
                        np.random.SeedSequence([config.seed, 20]).spawn(n_steppers)]
        fps = config.fps
        nav_body = (
            body_from_height(config.navigator_height_m)
            if config.navigator_height_m is not None
            else sample_body(rng_nav)
        )
        home = script.start_xy_m if script is not None else (0.0, 0.0)
        self.actors: list[_Actor] = [
            _Navigator(
                nav_body,
                sample_style(rng_nav),
                fps,
                rng_nav,
                script=script,
                repeat=config.repeat_script,
                chunk_s=config.chunk_s,
                home_xy=home,
            )
        ]
        for k, rng in enumerate(rng_steppers):
            own = steppers[k] if steppers else None
            self.actors.append(
                _Navigator(sample_body(rng), sample_style(rng), fps, rng, script=own,
                           repeat=config.repeat_script, chunk_s=config.chunk_s,
                           home_xy=own.start_xy_m if own is not None else STEPPER_HOMES_M[k],
                           name=f"{NAVIGATOR}{k + 2}")
            )
        for i, rng in enumerate(rng_people):
            self.actors.append(
                _Bystander(
                    f"bystander{i + 1}",
                    sample_body(rng),
                    sample_style(rng),
                    fps,
                    rng,
                    floor_half=cave.floor_half_size_m,
                    keep_clear=np.asarray(home),
                )
            )
        self.frame_index = 0

    @classmethod
    def build(cls, cave: CaveGeometry, config: SimConfig, script: MotionScript | None = None) -> SimWorld:
        """A world with the default cameras of :func:`default_cameras` for ``config.camera_preset``."""
        cams = default_cameras(cave, config.camera_preset, config.camera_count)
        return cls(cave, cams, config, script)

    @property
    def people(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.actors)

    def step(self, timestamp_s: float | None = None) -> SimFrame:
        """Advance one frame; ``timestamp_s`` None = simulation time (frame_index / fps)."""
        i = self.frame_index
        ts = i / self.config.fps if timestamp_s is None else float(timestamp_s)
        states = [a.step() for a in self.actors]
        joints = [s[0] for s in states]
        observed = (
            observe_with_ids(self.cameras, joints, i, ts, self._rng_views, self.config.faults)
            if self.config.observe
            else []
        )
        _, label, yaw, speed, tag, contacts = states[0]
        self.frame_index += 1
        return SimFrame(
            frame_index=i,
            timestamp_s=ts,
            truth=tuple((a.name, j) for a, j in zip(self.actors, joints, strict=True)),
            label=label,
            yaw_deg=yaw,
            speed_mps=speed,
            views=tuple(v for v, _ in observed),
            view_people=tuple(ids for _, ids in observed),
            tag=tag,
            contacts=contacts,
            labels=tuple(s[1] for s in states),
        )

    def run(self, n_frames: int | None = None, realtime: bool = False) -> Iterator[SimFrame]:
        """Yield ``n_frames`` frames (None = forever); ``realtime`` paces them at ``fps`` on the
        monotonic clock (timestamps are then monotonic-clock seconds, like a real camera's)."""
        period = 1.0 / self.config.fps
        t0 = time.monotonic()
        k = produced = 0
        while n_frames is None or produced < n_frames:
            if realtime:
                due = t0 + k * period
                delay = due - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
                elif delay < -1.0:  # fell far behind (a paused process): resynchronise
                    log.warning("simulator fell %.1f s behind real time; resynchronising", -delay)
                    t0, k = time.monotonic(), 0
                    due = t0
                yield self.step(timestamp_s=due)
            else:
                yield self.step()
            k += 1
            produced += 1
