"""The recognition chain, built one way for the live runtime, ``cavewalk process``,
``cavewalk bench`` and the tests (issue 16, item 2)::

    detector ──► pose stage (OC-SORT per view) ──► fusion (3D, navigator, recognition,
    (pose model on images,                          navigation, head pose) ──► FrameResult
     or the simulator)

A :class:`ChainConfig` (frozen, picklable: the stages' own configs) says what the chain is made
of; :func:`build_chain` builds it. The live runtime runs the chain's two halves in two worker
processes, each built here from the same config (:func:`build_pose_stage` in the detect or
simulator worker, :func:`build_fusion` in the fuse worker); ``cavewalk process`` and the tests
run :func:`build_chain`'s :class:`Chain` in one process.

The detector is the pose model on camera images (:class:`PoseModel`) or the simulator
(:class:`SimWorldFactory`, whose virtual cameras report detections without images); either way
the pose stage tracks, so fusion always gets tracked views.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.camera import Camera
from pipeline.cave import CaveGeometry
from pipeline.errors import ModelError
from pipeline.head.config import HeadConfig
from pipeline.head.tracker import HeadTracker
from pipeline.navigation.config import NavigationConfig
from pipeline.navigation.navigators import Navigators
from pipeline.pose.config import PoseConfig
from pipeline.pose.detector import PoseDetector
from pipeline.pose.roi import RoiScheduler
from pipeline.recognition.recognizer import ActionRecognizer, RecognizerConfig, open_session
from pipeline.results import FrameResult
from pipeline.runtime.messages import DetectedFrame, TrackedFrame
from pipeline.runtime.stages import Fusion, PoseStage, SimDetector
from pipeline.sim.scene import default_cameras
from pipeline.sim.script import MotionScript, load_script
from pipeline.sim.world import SimConfig, SimWorld
from pipeline.takes.teach import AdaptableSession, OutputAdaptation
from pipeline.tracking.ocsort import MultiViewTracker, OCSortConfig
from pipeline.tracking.stage import DetectAndTrack, StepTimings
from pipeline.triangulation.config import NavigatorConfig, ReconstructionConfig
from pipeline.triangulation.navigator import NavigatorSelector
from pipeline.triangulation.reconstructor import Reconstructor

log = logging.getLogger(__name__)


# ---------------------------------------------------------------------------------- detectors
@dataclass(frozen=True, slots=True)
class PoseModel:
    """The detector of camera images: the pose model's file and its section."""

    config: PoseConfig
    model_path: Path


@dataclass(frozen=True, slots=True)
class SimWorldFactory:
    """The simulator as a detector: builds ``pipeline.sim.world.SimWorld`` inside its worker.

    cameras: the virtual cameras (the fusion stage uses them as its calibration).
    fps: the rate the simulator worker steps the world at.
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


Detector = PoseModel | SimWorldFactory


# ------------------------------------------------------------------------------------- config
@dataclass(frozen=True, slots=True)
class ChainConfig:
    """What one recognition chain is made of: its views and the stages' own configs.

    cameras: the calibrated cameras (None: no 3D; then there are 2D tracks but no 3D people,
        navigator or action).
    camera_names: the views, in order (the pose stage tracks each).
    detector: the pose model (camera images) or the simulator; None: the detections are
        handed in (:meth:`Chain.update`: a script or test that steps its own simulator).
    recognition: None leaves actions out; adaptation: a participant's teach adaptation of the
        recogniser's outputs (issue 18 item 3).
    """

    cameras: tuple[Camera, ...] | None = None
    camera_names: tuple[str, ...] = ()
    detector: Detector | None = None
    tracking: OCSortConfig = field(default_factory=OCSortConfig)
    reconstruction: ReconstructionConfig = field(default_factory=ReconstructionConfig)
    navigator: NavigatorConfig = field(default_factory=NavigatorConfig)
    recognition: RecognizerConfig | None = field(default_factory=RecognizerConfig)
    head: HeadConfig = field(default_factory=HeadConfig)
    navigation: NavigationConfig = field(default_factory=NavigationConfig)
    adaptation: OutputAdaptation | None = None

    def __post_init__(self) -> None:
        if len(set(self.camera_names)) != len(self.camera_names):
            raise ValueError(f"camera_names must be distinct, got {list(self.camera_names)}")
        calibrated = [c.name for c in self.cameras or ()]
        if self.camera_names and not set(calibrated) <= set(self.camera_names):
            raise ValueError(f"calibrated cameras {sorted(set(calibrated) - set(self.camera_names))} are not "
                             f"among the views {list(self.camera_names)}")

    def with_views(self, detector: Detector, camera_names: tuple[str, ...],
                   cameras: tuple[Camera, ...] | None) -> ChainConfig:
        """This chain on a run's detector and views (the live runtime, at each start)."""
        return replace(self, detector=detector, camera_names=camera_names, cameras=cameras)

    def on_simulator(self, simulator: SimWorldFactory) -> ChainConfig:
        """This chain on the simulator: its virtual cameras are the views and the calibration."""
        return self.with_views(simulator, tuple(c.name for c in simulator.cameras), simulator.cameras)


# -------------------------------------------------------------------------------------- chain
class Chain:
    """The pose stage and fusion of one chain, in one process (``cavewalk process``, tests)."""

    def __init__(self, pose: PoseStage, fusion: Fusion) -> None:
        self.pose = pose
        self.fusion = fusion

    def images(self, frame_index: int, timestamp_s: float,
               images: list[NDArray[np.uint8]]) -> tuple[FrameResult, StepTimings]:
        """One multi-view frame of camera images (one per view, in order) -> its result."""
        views, timings = self.pose.detect(images, self.pose.cameras, frame_index, timestamp_s)
        detected = DetectedFrame(frame_index, timestamp_s, tuple(v.detections for v in views),
                                 timestamp_s, timestamp_s)
        return self.fusion.update(TrackedFrame(detected, views)), timings

    def update(self, frame: DetectedFrame) -> FrameResult:
        """A detector's detections of one multi-view frame (the simulator's) -> its result."""
        return self.fusion.update(TrackedFrame(frame, self.pose.track(frame.views)))


def build_pose_stage(config: ChainConfig) -> PoseStage:
    """The pose stage of ``config``'s views: OC-SORT per view, and with a :class:`PoseModel`
    detector the model loaded (onnxruntime) with its ROI scheduler."""
    tracker = MultiViewTracker(list(config.camera_names), config.tracking)
    if not isinstance(config.detector, PoseModel):
        return PoseStage(tracker)
    pose, path = config.detector.config, config.detector.model_path
    detector = PoseDetector.load(pose, path, pose.crop_model_file(path))
    return PoseStage(tracker, DetectAndTrack(detector, tracker, RoiScheduler(pose)))


def build_detector(config: ChainConfig) -> SimDetector:
    """The simulator of ``config`` as a detector (its world built here, in the simulator worker)."""
    if not isinstance(config.detector, SimWorldFactory):
        raise ValueError(f"the chain's detector is not the simulator: {type(config.detector).__name__}")
    return SimDetector(config.detector(), config.detector.fps)


def build_fusion(config: ChainConfig, *, need_actions: bool = False) -> Fusion:
    """Fusion of ``config``: with calibrated cameras the reconstructor, navigator choice, head pose,
    navigation and (``recognition``) the action model. An action model that does not load leaves
    the actions out with a warning (3D and the navigator still serve), or with ``need_actions``
    raises its :class:`ModelError`."""
    if config.cameras is None:
        return Fusion()
    recognizer = None
    if config.recognition is not None:
        try:
            session = open_session(config.recognition.model_path, config.recognition.threads)
            recognizer = ActionRecognizer(AdaptableSession(session, config.adaptation), config.recognition)
        except ModelError as exc:
            if need_actions:
                raise
            log.warning("no action recognition: %s", exc)
    return Fusion(Reconstructor(list(config.cameras), config.reconstruction),
                  NavigatorSelector(config.navigator), recognizer,
                  HeadTracker(config.head) if config.head.enabled else None,
                  Navigators(config.navigation, _per_person(recognizer)))


def build_chain(config: ChainConfig, *, need_actions: bool = False) -> Chain:
    """The whole chain of ``config`` in this process (see :func:`build_fusion` for ``need_actions``)."""
    return Chain(build_pose_stage(config), build_fusion(config, need_actions=need_actions))


def _per_person(recognizer: ActionRecognizer | None) -> Callable[[], ActionRecognizer] | None:
    """A factory of further recogniser states sharing ``recognizer``'s ONNX session (None: none)."""
    if recognizer is None:
        return None
    session, config = recognizer.session, recognizer.config
    return lambda: ActionRecognizer(session, config)


class FusionFactory(ChainConfig):
    """The chain's earlier name, kept for scripts that step their own simulator and feed its
    detections (``FusionFactory(...)().update(DetectedFrame(...))``): a :class:`ChainConfig`
    whose call is :func:`build_chain`. New code uses :func:`build_chain`."""

    __slots__ = ()

    def __call__(self) -> Chain:
        return build_chain(self)
