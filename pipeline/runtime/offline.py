"""The offline pipeline over synchronised video files (``cavewalk process``).

:class:`SyncedVideos` reads one frame of every video per step. :class:`OfflinePipeline` runs
each multi-view frame through the recognition chain (:func:`pipeline.runtime.chain.build_chain`,
the same stages the live runtime runs) and writes its :class:`FrameResult`.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError, SourceError
from pipeline.results import FrameResult, ResultsWriter
from pipeline.runtime.chain import Chain
from pipeline.tracking.stage import StepTimings

log = logging.getLogger(__name__)

U8 = NDArray[np.uint8]


# FFmpeg "decodes" a text file as a picture of its characters (the tty demuxer)
NOT_VIDEO_CODECS = frozenset({"ansi"})


def codec_name(cap: cv2.VideoCapture) -> str:
    """The stream's FourCC as text ('h264', 'mjpg', ...), '' when unknown."""
    code = int(cap.get(cv2.CAP_PROP_FOURCC)) & 0xFFFFFFFF
    return code.to_bytes(4, "little").decode("ascii", errors="replace").strip("\x00 ").lower()


def parse_named_paths(items: Sequence[str], what: str = "video") -> dict[str, Path]:
    """``["cam01=a.mp4", ...]`` -> {"cam01": Path("a.mp4")}; InputError on a malformed or repeated item."""
    out: dict[str, Path] = {}
    for item in items:
        name, sep, path = item.partition("=")
        name, path = name.strip(), path.strip()
        if not sep or not name or not path:
            raise InputError(f"--{what} {item!r}: expected NAME=PATH, e.g. cam01=videos/cam01.mp4")
        if name in out:
            raise InputError(f"--{what}: camera {name!r} given twice")
        out[name] = Path(path).expanduser()
    if not out:
        raise InputError(f"give at least one --{what} NAME=PATH")
    return out


@dataclass(frozen=True, slots=True)
class VideoInfo:
    camera: str
    path: Path
    frame_count: int  # as the container reports it (may be 0 when unknown)
    fps: float
    image_size: tuple[int, int]


class SyncedVideos:
    """Synchronised video files, one per camera, read frame by frame in step.

    Raises InputError for a missing file and SourceError for one OpenCV cannot decode.
    """

    def __init__(self, videos: Mapping[str, Path]) -> None:
        self._caps: dict[str, cv2.VideoCapture] = {}
        self.info: dict[str, VideoInfo] = {}
        self.frames_read: dict[str, int] = {}  # camera -> frames decoded so far
        self.ended: dict[str, int] = {}  # camera -> frames it really had, once it ran out
        try:
            for cam, path in videos.items():
                if not path.is_file():
                    raise InputError(f"camera {cam}: video file not found: {path}")
                cap = cv2.VideoCapture(str(path))
                ok, frame = cap.read() if cap.isOpened() else (False, None)
                if not ok or frame is None or codec_name(cap) in NOT_VIDEO_CODECS:
                    cap.release()
                    raise SourceError(
                        f"camera {cam}: cannot decode video {path} (not a video OpenCV can read)")
                cap.set(cv2.CAP_PROP_POS_FRAMES, 0)
                self._caps[cam] = cap
                self.info[cam] = VideoInfo(
                    cam, path, int(cap.get(cv2.CAP_PROP_FRAME_COUNT) or 0),
                    float(cap.get(cv2.CAP_PROP_FPS) or 0.0), (int(frame.shape[1]), int(frame.shape[0])),
                )
        except BaseException:
            self.close()
            raise

    @property
    def cameras(self) -> tuple[str, ...]:
        return tuple(self._caps)

    @property
    def fps(self) -> float:
        rates = [i.fps for i in self.info.values() if i.fps > 0]
        return min(rates) if rates else 30.0

    @property
    def frame_count(self) -> int:
        """Frames all videos have (as their containers report)."""
        counts = [i.frame_count for i in self.info.values()]
        return min(counts) if counts and min(counts) > 0 else 0

    def __iter__(self) -> Iterator[list[U8]]:
        """Multi-view frames (images in camera order) until the shortest video ends (it is
        recorded in :attr:`ended`, with the frames it really had)."""
        self.frames_read = dict.fromkeys(self._caps, 0)
        while True:
            frames = []
            for cam, cap in self._caps.items():
                ok, frame = cap.read()
                if not ok or frame is None:
                    self.ended[cam] = self.frames_read[cam]
                    return
                self.frames_read[cam] += 1
                frames.append(frame)
            yield frames

    def frames_had(self) -> dict[str, int]:
        """camera -> frames it really had, after the iteration stopped at the shortest video:
        the ones that ran out as recorded, the others counted to their end (frames skipped,
        not decoded). Call once, after iterating."""
        out: dict[str, int] = {}
        for cam, cap in self._caps.items():
            if cam in self.ended:
                out[cam] = self.ended[cam]
                continue
            n = self.frames_read.get(cam, 0)
            while cap.grab():
                n += 1
            out[cam] = self.ended[cam] = n
        return out

    def shortfall(self) -> dict[str, tuple[int, int]]:
        """camera -> (frames it really had, frames its file reports) for each video that ran out
        before the frames its container reports (a truncated or damaged file); call after
        :meth:`frames_had`."""
        return {cam: (n, self.info[cam].frame_count) for cam, n in self.ended.items()
                if self.info[cam].frame_count > 0 and n < self.info[cam].frame_count}

    def close(self) -> None:
        for cap in self._caps.values():
            cap.release()
        self._caps.clear()

    def __enter__(self) -> SyncedVideos:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass(slots=True)
class RunSummary:
    """What a run did: frames, frames per camera with a tracked person, per-frame timings."""

    frames: int = 0
    timings: list[StepTimings] = field(default_factory=list)
    track_frames: dict[str, dict[int, int]] = field(default_factory=dict)  # camera -> id -> frames
    wall_s: float = 0.0
    people3d_frames: int = 0  # frames with at least one 3D person
    navigator_frames: int = 0  # frames with a navigator
    actions: dict[str, int] = field(default_factory=dict)  # action label -> frames

    def median_ms(self) -> float:
        return float(np.median([t.total_s for t in self.timings]) * 1e3) if self.timings else float("nan")


class OfflinePipeline:
    """The recognition chain over multi-view frames of images, results to JSON Lines."""

    def __init__(self, chain: Chain) -> None:
        self.chain = chain

    def step(self, frame_index: int, timestamp_s: float,
             images: list[U8]) -> tuple[FrameResult, StepTimings]:
        """One multi-view frame (images in camera order) -> its result."""
        return self.chain.images(frame_index, timestamp_s, images)

    def run(
        self,
        videos: SyncedVideos,
        writer: ResultsWriter,
        max_frames: int | None = None,
        progress: Callable[[int, int, RunSummary], None] | None = None,
    ) -> RunSummary:
        """Process the videos (all frames, or the first ``max_frames``), writing one line per frame."""
        if tuple(videos.cameras) != self.chain.pose.cameras:
            raise InputError(f"videos {list(videos.cameras)} and tracker cameras "
                             f"{list(self.chain.pose.cameras)} differ")
        total = videos.frame_count
        if max_frames is not None:
            total = min(max_frames, total or max_frames)
        summary = RunSummary(track_frames={c: {} for c in videos.cameras})
        fps = videos.fps
        t0 = time.perf_counter()
        for k, images in enumerate(videos):
            if max_frames is not None and k >= max_frames:
                break
            result, timings = self.step(k, k / fps, images)
            writer.write(result)
            summary.frames += 1
            summary.timings.append(timings)
            summary.people3d_frames += bool(result.people3d)
            summary.navigator_frames += result.navigator is not None
            if result.action is not None:
                summary.actions[result.action.label] = summary.actions.get(result.action.label, 0) + 1
            for view in result.views:
                counts = summary.track_frames[view.camera]
                for tid in view.track_ids.tolist():
                    counts[tid] = counts.get(tid, 0) + 1
            if progress is not None:
                progress(k + 1, total, summary)
        summary.wall_s = time.perf_counter() - t0
        return summary
