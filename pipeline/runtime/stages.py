"""The stage objects the worker processes run, and the picklable factories that build them.

A worker process receives a *factory* (a small frozen dataclass of configs) and builds
its stage inside the process, so nothing heavy (an ONNX session) is pickled and tests
can hand a worker any other factory.

- :class:`PoseStage` — the pose detector over all views of a multi-view frame, in ROI
  mode on crops around the people seen in the previous frame (a full-frame pass every
  ``full_every`` frames or when a view saw nobody).
- :class:`Fusion` — tracking, association/triangulation, navigator choice, recognition.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from pipeline.camera import Camera
from pipeline.errors import ModelError
from pipeline.pose.types import ViewDetections
from pipeline.recognition.types import ActionEstimate
from pipeline.results import FrameResult
from pipeline.runtime.messages import DetectedFrame
from pipeline.tracking.types import TrackedView
from pipeline.triangulation.types import Person3D

log = logging.getLogger(__name__)

# --------------------------------------------------------------------------------- pose stage
class DetectStage(Protocol):
    def detect(self, images: Sequence[NDArray[np.uint8]], cameras: Sequence[str], frame_index: int,
               timestamp_s: float) -> tuple[ViewDetections, ...]: ...


class PoseStage:
    """Batched pose detection over the views of a multi-view frame, optionally in ROI mode.

    ROI mode uses the pose stage's :class:`pipeline.pose.roi.RoiScheduler`; the boxes it
    expects are the previous frame's confident detections (the tracker runs in another
    process), and a view that lost a person since the previous frame triggers a full pass.
    """

    def __init__(self, detector: Any, roi: Any = None, min_score: float = 0.35) -> None:
        from pipeline.pose.roi import RoiScheduler

        self.detector = detector
        self.scheduler = RoiScheduler(roi) if roi is not None else None
        self.min_score = min_score
        self._previous: dict[str, NDArray[np.float32]] = {}
        self.full_passes = 0
        self.roi_passes = 0

    def detect(self, images: Sequence[NDArray[np.uint8]], cameras: Sequence[str], frame_index: int,
               timestamp_s: float) -> tuple[ViewDetections, ...]:
        if self.scheduler is None:
            views = tuple(self.detector.detect(images, cameras, frame_index, timestamp_s).views)
            self.full_passes += 1
            return views
        sizes = [(int(im.shape[1]), int(im.shape[0])) for im in images]
        expected = [{i: b.astype(np.float64) for i, b in enumerate(self._previous.get(c, np.zeros((0, 4))))}
                    for c in cameras]
        plan = self.scheduler.plan(sizes, expected)
        batch = self.detector.detect(images, cameras, frame_index, timestamp_s, jobs=plan.jobs,
                                     net_size=plan.net_size)
        views = tuple(batch.views)
        lost = False
        for v in views:
            keep = v.boxes_xyxy[v.box_scores >= self.min_score]
            lost = lost or len(keep) < len(self._previous.get(v.camera, ()))
            self._previous[v.camera] = keep
        self.scheduler.report(plan.full, lost)
        if plan.full:
            self.full_passes += 1
        else:
            self.roi_passes += 1
        return views


@dataclass(frozen=True, slots=True)
class PoseStageFactory:
    """Builds the real pose stage (YOLO-pose on ONNX Runtime) inside the worker.

    detector_config: pipeline.pose.detector.PoseDetectorConfig; roi: pipeline.pose.roi.RoiConfig or None.
    """

    detector_config: Any
    roi: Any = None

    def __call__(self) -> PoseStage:
        from pipeline.pose.detector import PoseDetector

        session = load_quiet_session(self.detector_config)
        return PoseStage(PoseDetector(session, self.detector_config), self.roi,
                         self.detector_config.score_threshold)

    @classmethod
    def from_settings(cls, pose: Any, model_path: Path) -> PoseStageFactory:
        """From ``settings.pose`` (duck-typed: pipeline never imports app)."""
        from pipeline.pose.detector import PoseDetectorConfig
        from pipeline.pose.roi import RoiConfig

        roi = RoiConfig.from_settings(pose) if getattr(pose, "roi", False) else None
        return cls(PoseDetectorConfig.from_settings(pose, model_path), roi)


def load_quiet_session(config: Any) -> Any:
    """The pose model's onnxruntime session with spin-waiting threads off.

    onnxruntime's worker threads spin between runs by default; in a pipeline of several
    processes on few cores that spinning takes the CPU the capture decoders need (measured
    here: detect p50 918 ms spinning vs 141 ms not, four 1088x1920 decoders on 2 cores).
    Otherwise as ``pipeline.pose.detector.load_session``, whose checks it reuses.
    """
    import onnxruntime as ort

    from pipeline.pose import detector as pose

    path = Path(config.model_path)
    if not path.is_file():
        raise ModelError(f"pose model not found: {path} (run  cavewalk models prepare)")
    opts = ort.SessionOptions()
    opts.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    opts.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    opts.add_session_config_entry("session.intra_op.allow_spinning", "0")
    opts.add_session_config_entry("session.inter_op.allow_spinning", "0")
    if config.threads:
        opts.intra_op_num_threads = config.threads
        opts.inter_op_num_threads = 1
    available = set(ort.get_available_providers())
    providers = [pose.PROVIDERS[p] for p in config.providers if pose.PROVIDERS[p] in available]
    if "CPUExecutionProvider" not in providers:
        providers.append("CPUExecutionProvider")
    try:
        session = ort.InferenceSession(str(path), opts, providers=providers)
    except Exception as exc:  # onnxruntime raises its own exception types
        raise ModelError(f"{path}: onnxruntime cannot load it ({exc})") from exc
    out = session.get_outputs()[0].shape
    if len(session.get_inputs()) != 1 or len(out) != 3:
        raise ModelError(f"{path}: expected one (B, 3, H, W) input and a (B, 56, N) output")
    return session


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
                 selector: Selector | None, recognizer: Recognizer | None) -> None:
        self.tracker = tracker
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

    def take_changes(self) -> tuple[Any, ...]:
        out, self.changes = tuple(self.changes), []
        return out

    def update(self, frame: DetectedFrame) -> FrameResult:
        views = list(frame.views)
        tracked: tuple[TrackedView, ...] = ()
        if self.tracker is not None:
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
        if navigator != self._navigator and self.recognizer is not None:
            self.recognizer.reset()
        self._navigator = navigator
        if navigator is not None and self.recognizer is not None:
            person = next((p for p in people if p.user_id == navigator), None)
            if person is not None:
                action = self.recognizer.update(person.joints_m, frame.timestamp_s)
        return FrameResult(frame.frame_index, frame.timestamp_s, tracked, people, navigator, action)


@dataclass(frozen=True, slots=True)
class FusionFactory:
    """Builds :class:`Fusion` inside the worker from the stages' own configs.

    cameras: the calibrated cameras (None: no 3D). Any config left None leaves its part out.
    """

    cameras: tuple[Camera, ...] | None
    camera_names: tuple[str, ...]
    tracking: Any = None  # pipeline.tracking.ocsort.OCSortConfig
    reconstruction: Any = None  # pipeline.triangulation.config.ReconstructionConfig
    navigator: Any = None  # pipeline.triangulation.config.NavigatorConfig
    recognition: Any = None  # pipeline.recognition.recognizer.RecognizerConfig
    options: dict[str, Any] = field(default_factory=dict)

    def __call__(self) -> Fusion:
        from pipeline.tracking.ocsort import MultiViewTracker

        tracker = MultiViewTracker(list(self.camera_names), self.tracking)
        reconstructor = selector = recognizer = None
        if self.cameras is not None:
            try:
                from pipeline.triangulation.navigator import NavigatorSelector
                from pipeline.triangulation.reconstructor import Reconstructor
            except ImportError as exc:
                raise ModelError(f"the triangulation stage is not available: {exc}") from exc
            reconstructor = Reconstructor(list(self.cameras), self.reconstruction)
            selector = NavigatorSelector(self.navigator)
            if self.recognition is not None:
                from pipeline.recognition.recognizer import ActionRecognizer

                try:
                    recognizer = ActionRecognizer.from_config(self.recognition)
                except ModelError as exc:  # 3D and the navigator still serve without actions
                    log.warning("no action recognition: %s", exc)
        return Fusion(tracker, reconstructor, selector, recognizer)  # type: ignore[arg-type]


def fusion_factory_from_settings(settings: Any, cameras: list[Camera] | None) -> FusionFactory:
    """The fusion stage's configs from the settings sections that exist (others: their defaults)."""
    from pipeline.recognition.recognizer import RecognizerConfig
    from pipeline.tracking.ocsort import OCSortConfig

    tracking = OCSortConfig.from_settings(settings.tracking) if hasattr(settings, "tracking") else None
    recognition = RecognizerConfig.from_settings(settings.recognition)
    return FusionFactory(cameras=tuple(cameras) if cameras else None, camera_names=(), tracking=tracking,
                         recognition=recognition)


# ---------------------------------------------------------------------------------- simulator
@dataclass(frozen=True, slots=True)
class SimWorldFactory:
    """Builds the simulator (``pipeline.sim.world.SimWorld``) inside its worker.

    cameras: the virtual cameras (the fusion stage uses them as its calibration).
    config: pipeline.sim.world.SimConfig.
    """

    cave: Any  # pipeline.cave.CaveGeometry
    cameras: tuple[Camera, ...]
    config: Any
    fps: float

    def __post_init__(self) -> None:
        if not self.cameras:
            raise ValueError("the simulator needs at least one camera, got none")
        if self.fps <= 0:
            raise ValueError(f"fps must be > 0, got {self.fps}")

    def __call__(self) -> Any:
        from pipeline.sim.world import SimWorld

        return SimWorld(self.cave, list(self.cameras), self.config)

    @classmethod
    def from_settings(cls, sim: Any, cave: Any, camera_count: int = 4, **overrides: Any) -> SimWorldFactory:
        """From ``settings.sim`` and the CAVE geometry; ``overrides`` go to SimConfig (e.g. fps=60)."""
        from pipeline.sim.scene import default_cameras
        from pipeline.sim.world import SimConfig

        fields = {"fps": sim.fps, "bystanders": sim.bystanders, "seed": sim.seed,
                  "camera_preset": sim.camera_preset, "camera_count": camera_count}
        fields.update(overrides)
        config = SimConfig(**fields)
        cameras = tuple(default_cameras(cave, config.camera_preset, config.camera_count))
        return cls(cave, cameras, config, config.fps)
