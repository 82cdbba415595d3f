"""The stage objects of the recognition chain (built by :mod:`pipeline.runtime.chain`).

- :class:`PoseStage` — the people of every view of a multi-view frame, tracked per view
  (OC-SORT): the one place tracking happens. Its detector is the pose model on camera images
  (:meth:`PoseStage.detect`, in ROI mode on crops around each view's predicted tracks) or any
  detector whose detections are handed in (:meth:`PoseStage.track`): the simulator's.
- :class:`SimDetector` — the simulator as a detector: its virtual cameras report what a pose
  model would see, frame by frame.
- :class:`Fusion` — association/triangulation, navigator choice, recognition, navigation and
  head pose, over tracked views.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import replace
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError, ModelError
from pipeline.head.tracker import HeadEstimate, HeadTracker
from pipeline.navigation.navigators import Navigators
from pipeline.pose.types import ViewDetections
from pipeline.recognition.types import ActionEstimate
from pipeline.results import FrameResult
from pipeline.runtime.messages import TrackedFrame
from pipeline.sim.world import SimWorld
from pipeline.takes.teach import AdaptableSession, OutputAdaptation
from pipeline.tracking.ocsort import MultiViewTracker
from pipeline.tracking.stage import DetectAndTrack, StepTimings
from pipeline.tracking.types import TrackedView
from pipeline.triangulation.navigator import NavigatorChange
from pipeline.triangulation.types import Person3D

log = logging.getLogger(__name__)


# --------------------------------------------------------------------------------- pose stage
class PoseStage:
    """The people of every view, tracked per view by one :class:`MultiViewTracker`.

    With the pose model (``model``, a :class:`DetectAndTrack` sharing ``tracker``) it takes camera
    images: the crops follow the tracks, so detection and tracking run in one step. Any other
    detector (the simulator) hands its detections to :meth:`track`. Either way fusion gets tracked
    views, and the tracks are kept here, in the process of the detector.
    """

    def __init__(self, tracker: MultiViewTracker, model: DetectAndTrack | None = None) -> None:
        if model is not None and model.tracker is not tracker:
            raise ValueError("the pose model's DetectAndTrack must track with this stage's tracker")
        self.tracker = tracker
        self.model = model

    @property
    def cameras(self) -> tuple[str, ...]:
        return self.tracker.cameras

    def detect(self, images: Sequence[NDArray[np.uint8]], cameras: Sequence[str], frame_index: int,
               timestamp_s: float) -> tuple[tuple[TrackedView, ...], StepTimings]:
        """The pose model on one multi-view frame's images (in the order of ``cameras``, which may
        lack some views: late or gone), then OC-SORT on the views present."""
        if self.model is None:
            raise ModelError("this pose stage has no pose model: its detections are handed in (track)")
        return self.model.step(images, frame_index, timestamp_s, cameras)

    def track(self, views: Sequence[ViewDetections]) -> tuple[TrackedView, ...]:
        """Another detector's detections of one multi-view frame (the simulator's), tracked."""
        return self.tracker.update(views)


class SimDetector:
    """The simulator as the pose stage's detector: each step advances its world by one frame and
    returns what the virtual cameras' pose model would report (no images)."""

    def __init__(self, world: SimWorld, fps: float) -> None:
        if fps <= 0:
            raise ValueError(f"fps must be > 0, got {fps}")
        self.world = world
        self.fps = fps  # the rate its worker steps it at

    @property
    def cameras(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.world.cameras)

    def detect(self, frame_index: int, timestamp_s: float) -> tuple[ViewDetections, ...]:
        views = self.world.step(timestamp_s=timestamp_s).views
        return tuple(v if v.frame_index == frame_index else replace(v, frame_index=frame_index)
                     for v in views)


# ------------------------------------------------------------------------------------- fusion
class Reconstructor(Protocol):
    """pipeline.triangulation.reconstructor.Reconstructor."""

    def update(self, views: Sequence[TrackedView], timestamp_s: float) -> Sequence[Person3D]: ...

    def number_from(self, first_user_id: int) -> None: ...


class Recognizer(Protocol):
    """pipeline.recognition.recognizer.ActionRecognizer."""

    def update(self, joints_m: NDArray[np.floating], timestamp_s: float) -> ActionEstimate: ...

    def reset(self) -> None: ...


class Selector(Protocol):
    """pipeline.triangulation.navigator.NavigatorSelector."""

    @property
    def current(self) -> int | None: ...

    @property
    def mode(self) -> str: ...

    def update(self, people: Sequence[Person3D], timestamp_s: float) -> NavigatorChange | None: ...

    def set_manual(self, user_id: int) -> NavigatorChange | None: ...

    def set_auto(self) -> NavigatorChange | None: ...

    def resume_manual(self, user_id: int, xy_m: tuple[float, float]) -> None: ...


class Fusion:
    """Association/triangulation -> navigator -> recognition -> navigation, head pose, for one
    tracked multi-view frame.

    Parts that are None are skipped: without a reconstructor (no calibration) there are
    2D tracks but no 3D people, navigator or action.
    """

    def __init__(self, reconstructor: Reconstructor | None = None, selector: Selector | None = None,
                 recognizer: Recognizer | None = None, heads: HeadTracker | None = None,
                 navigation: Navigators | None = None) -> None:
        self.navigation = navigation  # issue 20: several navigators (None: single mode only)
        self.heads = heads
        self.reconstructor = reconstructor
        self.selector = selector
        self.recognizer = recognizer
        self._navigator: int | None = None
        self.changes: list[NavigatorChange] = []  # navigator changes since the last take_changes()

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
            raise InputError("navigation modes need the 3D stage (a calibration)")
        self.navigation.set_mode(mode, user_ids)

    def resume_navigator(self, user_id: int, xy_m: tuple[float, float]) -> None:
        """The operator's navigator of the fusion worker before, re-acquired where last seen."""
        if self.selector is not None:
            self.selector.resume_manual(user_id, xy_m)

    def number_from(self, first_user_id: int) -> None:
        """New people get user ids from ``first_user_id`` on (a fusion worker started again)."""
        if self.reconstructor is not None:
            self.reconstructor.number_from(first_user_id)

    def take_changes(self) -> tuple[NavigatorChange, ...]:
        out, self.changes = tuple(self.changes), []
        return out

    def set_adaptation(self, adaptation: OutputAdaptation | None) -> None:
        """A participant's teach adaptation of the model's outputs (None: the model alone), for every
        recogniser sharing the session (pipeline.takes.teach)."""
        session = getattr(self.recognizer, "session", None)
        if isinstance(session, AdaptableSession):
            session.set_adaptation(adaptation)

    def update(self, frame: TrackedFrame) -> FrameResult:
        tracked, t = frame.views, frame.timestamp_s
        people: tuple[Person3D, ...] = ()
        if self.reconstructor is not None:
            people = tuple(self.reconstructor.update(tracked, t))
        navigator = None
        if self.selector is not None:
            change = self.selector.update(people, t)
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
                action = self.recognizer.update(person.joints_m, t)
        nav = None
        users: tuple[int, ...] = () if navigator is None else (navigator,)
        if self.navigation is not None:
            nav = self.navigation.update(people, t, navigator, action)
            if not single:  # each person's own state decides; the navigator's is theirs
                own = nav.command_of(navigator) if navigator is not None else None
                action = own.action if own is not None else None
                users = nav.user_ids
        heads: tuple[HeadEstimate, ...] = ()
        if self.heads is not None and users:
            heads = self.heads.update(people, t, users=users)
        return FrameResult(frame.frame_index, t, tracked, people, navigator, action, heads, navigation=nav)


def __getattr__(name: str) -> object:
    """``FusionFactory``, the chain's earlier name, where scripts import it from (it lives in
    :mod:`pipeline.runtime.chain`, which imports this module)."""
    if name == "FusionFactory":
        from pipeline.runtime.chain import FusionFactory

        return FusionFactory
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
