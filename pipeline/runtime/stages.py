"""The stage objects the worker processes run, and the picklable factories that build them.

A worker process receives a *factory* (a small frozen dataclass of configs) and builds
its stage inside the process, so nothing heavy (an ONNX session) is pickled and tests
can hand a worker any other factory.

- :class:`PoseStage` — the pose detector over all views of a multi-view frame, in ROI
  mode on crops around each view's predicted tracks, then OC-SORT per view.
- :class:`Fusion` — association/triangulation, navigator choice, recognition, head pose (and the
  tracking itself for the simulator, whose detections skip the pose stage).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from pipeline.camera import Camera
from pipeline.cave import CaveGeometry
from pipeline.errors import ModelError
from pipeline.head.config import HeadConfig
from pipeline.head.tracker import HeadEstimate, HeadTracker
from pipeline.navigation.config import NavigationConfig
from pipeline.navigation.navigators import Navigators
from pipeline.pose.config import PoseConfig
from pipeline.pose.detector import PoseDetector
from pipeline.pose.roi import RoiScheduler
from pipeline.pose.types import ViewDetections
from pipeline.recognition.recognizer import ActionRecognizer, RecognizerConfig, open_session
from pipeline.recognition.types import ActionEstimate
from pipeline.results import FrameResult
from pipeline.runtime.messages import DetectedFrame
from pipeline.sim.scene import default_cameras
from pipeline.sim.script import MotionScript, load_script
from pipeline.sim.world import SimConfig, SimWorld
from pipeline.takes.teach import AdaptableSession, OutputAdaptation
from pipeline.tracking.ocsort import MultiViewTracker, OCSortConfig
from pipeline.tracking.stage import DetectAndTrack
from pipeline.tracking.types import TrackedView
from pipeline.triangulation.config import NavigatorConfig, ReconstructionConfig
from pipeline.triangulation.types import Person3D

log = logging.getLogger(__name__)

# --------------------------------------------------------------------------------- pose stage
class PoseStage:
    """Pose detection over the views of a multi-view frame, then OC-SORT per view.

    :class:`pipeline.tracking.stage.DetectAndTrack` for a frame that may lack some cameras
    (late or gone): ROI crops around each present view's predicted tracks, the trackers of
    the present views updated. Runs in the detect process so the crops follow the tracks.
    """

    def __init__(self, detector: Any, tracker: Any, roi: Any) -> None:
        self.detect_track = DetectAndTrack(detector, tracker, roi)

    def detect(self, images: Sequence[NDArray[np.uint8]], cameras: Sequence[str], frame_index: int,
               timestamp_s: float) -> tuple[TrackedView, ...]:
        return self.detect_track.step(images, frame_index, timestamp_s, cameras)[0]


@dataclass(frozen=True, slots=True)
class PoseStageFactory:
    """Builds the pose + tracking stage inside the detect worker (loads the ONNX model there)."""

    pose: PoseConfig
    model_path: Path
    tracking: OCSortConfig = field(default_factory=OCSortConfig)
    cameras: tuple[str, ...] = ()

    def __call__(self) -> PoseStage:
        if not self.cameras:
            raise ValueError("PoseStageFactory needs the camera names (use with_cameras)")
        detector = PoseDetector.load(self.pose, self.model_path, self.pose.crop_model_file(self.model_path))
        tracker = MultiViewTracker(list(self.cameras), self.tracking)
        return PoseStage(detector, tracker, RoiScheduler(self.pose))

    def with_cameras(self, cameras: Sequence[str]) -> PoseStageFactory:
        return replace(self, cameras=tuple(cameras))


# ------------------------------------------------------------------------------------- fusion
class Tracker(Protocol):
    def update(self, views: Sequence[ViewDetections]) -> Sequence[TrackedView]: ...


class Reconstructor(Protocol):
    def update(self, views: Sequence[TrackedView], timestamp_s: float) -> Sequence[Person3D]: ...


class Recognizer(Protocol):
    def update(self, joints_m: NDArray[np.floating], timestamp_s: float) -> ActionEstimate: ...

    def reset(self) -> None: ...


class Selector(Protocol):
    """pipeline.triangulation.navigator.NavigatorSelector."""

    @property
    def current(self) -> int | None: ...

    @property
    def mode(self) -> str: ...

    def update(self, people: Sequence[Person3D], timestamp_s: float) -> Any: ...

    def set_manual(self, user_id: int) -> Any: ...

    def set_auto(self) -> Any: ...


class Fusion:
    """Tracking -> association/triangulation -> navigator -> recognition, for one multi-view frame.

    Parts that are None are skipped: without a reconstructor (no calibration) there are
    2D tracks but no 3D people, navigator or action.
    """

    def __init__(self, tracker: Tracker | None, reconstructor: Reconstructor | None,
                 selector: Selector | None, recognizer: Recognizer | None,
                 heads: HeadTracker | None = None, navigation: Navigators | None = None) -> None:
        self.tracker = tracker
        self.navigation = navigation  # issue 20: several navigators (None: single mode only)
        self.heads = heads
        self.reconstructor = reconstructor
        self.selector = selector
        self.recognizer = recognizer
        self._navigator: int | None = None
        self.changes: list[Any] = []  # navigator changes since the last take_changes()

    @property
    def mode(self) -> str:
        return self.selector.mode if self.selector is not None else "auto"

    def set_navigator(self, user_id: int | None) -> None:
        """None = automatic choice; raises InputError (nothing changes) for an untracked user."""
        if self.selector is None:
            return
        change = self.selector.set_auto() if user_id is None else self.selector.set_manual(user_id)
        if change is not None:
            self.changes.append(change)

    def set_navigation(self, mode: str, user_ids: Sequence[int] = ()) -> None:
        """The navigation mode (pipeline.navigation); InputError (nothing changes) for a bad one."""
        if self.navigation is None:
            from pipeline.errors import InputError

            raise InputError("navigation modes need the 3D stage (a calibration)")
        self.navigation.set_mode(mode, user_ids)

    def take_changes(self) -> tuple[Any, ...]:
        out, self.changes = tuple(self.changes), []
        return out

    def set_adaptation(self, adaptation: OutputAdaptation | None) -> None:
        """A participant's teach adaptation of the model's outputs (None: the model alone), for every
        recogniser sharing the session (pipeline.takes.teach)."""
        session = getattr(self.recognizer, "session", None)
        if isinstance(session, AdaptableSession):
            session.set_adaptation(adaptation)

    def update(self, frame: DetectedFrame) -> FrameResult:
        views = list(frame.views)
        tracked: tuple[TrackedView, ...] = ()
        if frame.tracked is not None:  # tracked in the detect process already
            tracked = frame.tracked
        elif self.tracker is not None:
            tracked = tuple(self.tracker.update(views))
        people: tuple[Person3D, ...] = ()
        if self.reconstructor is not None:
            people = tuple(self.reconstructor.update(tracked, frame.timestamp_s))
        navigator = None
        if self.selector is not None:
            change = self.selector.update(people, frame.timestamp_s)
            if change is not None:
                self.changes.append(change)
            navigator = self.selector.current
        action = None
        single = self.navigation is None or self.navigation.mode == "single"
        if navigator != self._navigator and self.recognizer is not None:
            self.recognizer.reset()
        self._navigator = navigator
        if single and navigator is not None and self.recognizer is not None:
            person = next((p for p in people if p.user_id == navigator), None)
            if person is not None:
                action = self.recognizer.update(person.joints_m, frame.timestamp_s)
        nav = None
        users: tuple[int, ...] = () if navigator is None else (navigator,)
        if self.navigation is not None:
            nav = self.navigation.update(people, frame.timestamp_s, navigator, action)
            if not single:  # each person's own state decides; the navigator's is theirs
                own = nav.command_of(navigator) if navigator is not None else None
                action = own.action if own is not None else None
                users = nav.user_ids
        heads: tuple[HeadEstimate, ...] = ()
        if self.heads is not None and users:
            heads = self.heads.update(people, frame.timestamp_s, users=users)
        return FrameResult(frame.frame_index, frame.timestamp_s, tracked, people, navigator, action, heads,
                           navigation=nav)


@dataclass(frozen=True, slots=True)
class FusionFactory:
    """Builds :class:`Fusion` inside the worker from the stages' own configs.

    cameras: the calibrated cameras (None: no 3D). Any config left None leaves its part out.
    """

    cameras: tuple[Camera, ...] | None
    camera_names: tuple[str, ...]
    tracking: OCSortConfig = field(default_factory=OCSortConfig)
    reconstruction: ReconstructionConfig = field(default_factory=ReconstructionConfig)
    navigator: NavigatorConfig = field(default_factory=NavigatorConfig)
    recognition: RecognizerConfig | None = field(default_factory=RecognizerConfig)  # None: no actions
    head: HeadConfig = field(default_factory=HeadConfig)
    navigation: NavigationConfig = field(default_factory=NavigationConfig)
    adaptation: OutputAdaptation | None = None  # a participant's teach adaptation (issue 18 item 3)

    def __call__(self) -> Fusion:
        tracker = MultiViewTracker(list(self.camera_names), self.tracking)
        reconstructor = selector = recognizer = heads = navigation = None
        if self.cameras is not None:
            try:
                from pipeline.triangulation.navigator import NavigatorSelector
                from pipeline.triangulation.reconstructor import Reconstructor
            except ImportError as exc:
                raise ModelError(f"the triangulation stage is not available: {exc}") from exc
            reconstructor = Reconstructor(list(self.cameras), self.reconstruction)
            selector = NavigatorSelector(self.navigator)
            heads = HeadTracker(self.head) if self.head.enabled else None
            if self.recognition is not None:
                try:
                    session = open_session(self.recognition.model_path, self.recognition.threads)
                    adaptable = AdaptableSession(session, self.adaptation)
                    recognizer = ActionRecognizer(adaptable, self.recognition)
                except ModelError as exc:  # 3D and the navigator still serve without actions
                    log.warning("no action recognition: %s", exc)
            navigation = Navigators(self.navigation, _per_person(recognizer))
        return Fusion(tracker, reconstructor, selector, recognizer, heads,  # type: ignore[arg-type]
                      navigation)


def _per_person(recognizer: ActionRecognizer | None) -> Any:
    """A factory of further recogniser states sharing ``recognizer``'s ONNX session (None: none)."""
    if recognizer is None:
        return None
    session, config = recognizer.session, recognizer.config
    return lambda: ActionRecognizer(session, config)


# ---------------------------------------------------------------------------------- simulator
@dataclass(frozen=True, slots=True)
class SimWorldFactory:
    """Builds the simulator (``pipeline.sim.world.SimWorld``) inside its worker.

    cameras: the virtual cameras (the fusion stage uses them as its calibration).
    config: pipeline.sim.world.SimConfig.
    """

    cave: CaveGeometry
    cameras: tuple[Camera, ...]
    config: SimConfig
    fps: float
    script: MotionScript | None = None  # the navigator's routine; None = random routines

    def __post_init__(self) -> None:
        if not self.cameras:
            raise ValueError("the simulator needs at least one camera, got none")
        if self.fps <= 0:
            raise ValueError(f"fps must be > 0, got {self.fps}")

    def __call__(self) -> SimWorld:
        return SimWorld(self.cave, list(self.cameras), self.config, self.script)

    @classmethod
    def build(cls, config: SimConfig, cave: CaveGeometry) -> SimWorldFactory:
        """The simulator of ``config`` (its routine file loaded here, so a bad one fails before any
        process starts) in the CAVE ``cave``."""
        script = load_script(config.script) if config.script is not None else None
        cameras = tuple(default_cameras(cave, config.camera_preset, config.camera_count))
        return cls(cave, cameras, config, config.fps, script)
