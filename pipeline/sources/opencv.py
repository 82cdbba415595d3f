"""Sources read with OpenCV: live cameras (device index, RTSP/HTTP URL), video files, image folders.

Video files can also be decoded with PyAV into their native I420 frames (``native=True``).

Paced sources deliver frame ``k`` at ``start_s + k / pace_fps`` on ``time.monotonic()``;
several sources given the same ``start_s`` stay in step, like cameras on one trigger.
A paced source that falls behind its clock skips the frames it missed (a live camera
does not wait either) and counts them in ``skipped``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from pipeline.errors import SourceError
from pipeline.sources.types import CapturedFrame

log = logging.getLogger(__name__)

Alloc = Callable[[tuple[int, ...]], np.ndarray]  # shape -> an array to deliver a frame in
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")


class Pacer:
    """Real-time schedule: slot k is due at ``start_s + k / fps``."""

    def __init__(self, fps: float, start_s: float | None = None) -> None:
        if fps <= 0:
            raise ValueError(f"pace fps must be > 0, got {fps}")
        self.period_s = 1.0 / fps
        self.start_s = time.monotonic() if start_s is None else start_s

    def due_slot(self, now: float) -> int:
        """The slot whose time has most recently come (-1 before the start)."""
        return int(np.floor((now - self.start_s) / self.period_s + 1e-9))

    def wait_for(self, slot: int) -> float:
        """Sleep until slot ``slot`` is due; returns the time it was due."""
        due = self.start_s + slot * self.period_s
        delay = due - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        return due


class _OpenCVReader:
    """Frames of a video file through OpenCV, as BGR."""

    def __init__(self, name: str, path: Path) -> None:
        self._cap = cv2.VideoCapture(str(path))
        if not self._cap.isOpened():
            raise SourceError(f"camera {name}: cannot open video {path}")
        fps = float(self._cap.get(cv2.CAP_PROP_FPS) or 0.0)
        self.fps = fps if fps > 0 else None
        self.frame_count = int(self._cap.get(cv2.CAP_PROP_FRAME_COUNT) or 0)

    def grab(self) -> bool:
        return bool(self._cap.grab())

    def rewind(self) -> None:
        self._cap.set(cv2.CAP_PROP_POS_FRAMES, 0)

    def retrieve(self, alloc: Alloc | None = None) -> np.ndarray | None:
        ok, image = self._cap.retrieve()
        return _into(_bgr(image), alloc) if ok and image is not None else None

    def release(self) -> None:
        self._cap.release()


class _PyAVReader:
    """Frames of a video file through PyAV (FFmpeg), as the decoder's own I420.

    One decoding thread per file: the capture workers already decode the cameras side by
    side, and frame threading would only add hand-over work on a few cores.
    """

    def __init__(self, name: str, path: Path) -> None:
        import av  # a runtime dependency; imported here so OpenCV-only uses do not load it

        try:
            self._container = av.open(str(path))
            self._stream = self._container.streams.video[0]
        except (av.FFmpegError, IndexError) as exc:
            raise SourceError(f"camera {name}: cannot open video {path} ({exc})") from exc
        self._stream.thread_count = 1
        self._name = name
        self._path = path
        rate = self._stream.average_rate or self._stream.guessed_rate
        self.fps = float(rate) if rate else None
        self.frame_count = int(self._stream.frames or 0)
        self._frames = self._container.decode(self._stream)
        self._frame: Any = None

    def grab(self) -> bool:
        import av

        try:
            self._frame = next(self._frames)
        except StopIteration:
            self._frame = None
            return False
        except av.FFmpegError as exc:
            raise SourceError(f"camera {self._name}: decoding {self._path} failed ({exc})") from exc
        return True

    def rewind(self) -> None:
        self._container.seek(0, stream=self._stream)
        self._frames = self._container.decode(self._stream)

    def retrieve(self, alloc: Alloc | None = None) -> np.ndarray | None:
        frame = self._frame
        if frame is None:
            return None
        w, h = frame.width, frame.height
        if w % 2 or h % 2:
            return _into(np.ascontiguousarray(frame.to_ndarray(format="bgr24")), alloc)
        if frame.format.name != "yuv420p":  # another layout or depth: FFmpeg converts it
            return _into(np.ascontiguousarray(frame.to_ndarray(format="yuv420p")), alloc)
        out = alloc((h * 3 // 2, w)) if alloc is not None else np.empty((h * 3 // 2, w), np.uint8)
        flat, pos = out.reshape(-1), 0
        for plane, (ph, pw) in zip(frame.planes, ((h, w), (h // 2, w // 2), (h // 2, w // 2)), strict=True):
            rows = np.frombuffer(plane, np.uint8)[: ph * plane.line_size].reshape(ph, plane.line_size)
            flat[pos: pos + ph * pw].reshape(ph, pw)[...] = rows[:, :pw]  # planes are padded per row
            pos += ph * pw
        return out

    def release(self) -> None:
        self._container.close()


class VideoFileSource:
    """A video file, once or looping, paced in real time or read flat out (``pace_fps=None``).

    native: frames in the decoder's own I420 (:mod:`pipeline.pixels`), decoded with PyAV,
    instead of BGR through OpenCV; the live pipeline's capture workers ask for them.
    """

    def __init__(self, name: str, path: Path, *, loop: bool = False, pace_fps: float | None = None,
                 start_s: float | None = None, drop_late: bool = True, native: bool = False) -> None:
        path = Path(path)
        if not path.is_file():
            raise SourceError(f"camera {name}: video file not found: {path}")
        self.name = name
        self.path = path
        self.loop = loop
        self.drop_late = drop_late
        self._reader: _OpenCVReader | _PyAVReader | None = (
            _PyAVReader(name, path) if native else _OpenCVReader(name, path))
        self._fps = self._reader.fps
        self.frame_count = self._reader.frame_count
        self._pacer = Pacer(pace_fps, start_s) if pace_fps else None
        self._next = 0  # next delivery slot (paced) / frame counter (flat out)
        self.skipped = 0
        self.loops = 0

    @property
    def nominal_fps(self) -> float | None:
        return self._fps

    def _grab(self) -> bool:
        assert self._reader is not None
        if self._reader.grab():
            return True
        if not self.loop:
            return False
        self.loops += 1
        self._reader.rewind()
        return self._reader.grab()

    def grab(self) -> bool:
        """Take the next frame off the file when it is due, without converting it (False: ended)."""
        if self._reader is None:
            return False
        if self._pacer is not None:
            due = self._pacer.due_slot(time.monotonic())
            if self.drop_late and due > self._next:  # behind the clock: skip what was missed
                for _ in range(due - self._next):
                    if not self._grab():
                        return False
                    self.skipped += 1
                self._next = due
            self._pacer.wait_for(self._next)
        if not self._grab():
            return False
        self._next += 1
        return True

    def retrieve(self, alloc: Alloc | None = None) -> CapturedFrame | None:
        """The frame last grabbed (BGR, or I420 when native; None if it cannot be decoded), in an
        array from ``alloc(shape)`` when given (a shared-memory slot, say)."""
        if self._reader is None:
            return None
        image = self._reader.retrieve(alloc)
        if image is None:
            return None
        return CapturedFrame(self.name, self._next - 1, time.monotonic(), image)

    def read(self) -> CapturedFrame | None:
        return self.retrieve() if self.grab() else None

    def close(self) -> None:
        if self._reader is not None:
            self._reader.release()
            self._reader = None


class ImageFolderSource:
    """The images of a folder in name order, as frames (paced or flat out, once or looping)."""

    def __init__(self, name: str, folder: Path, *, loop: bool = False, pace_fps: float | None = None,
                 start_s: float | None = None) -> None:
        folder = Path(folder)
        if not folder.is_dir():
            raise SourceError(f"camera {name}: image folder not found: {folder}")
        self.files = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        if not self.files:
            raise SourceError(f"camera {name}: no images ({', '.join(IMAGE_SUFFIXES)}) in {folder}")
        self.name = name
        self.loop = loop
        self._pace_fps = pace_fps
        self._pacer = Pacer(pace_fps, start_s) if pace_fps else None
        self._next = 0
        self._closed = False

    @property
    def nominal_fps(self) -> float | None:
        return self._pace_fps

    def grab(self) -> bool:
        """Wait for the next image's slot (False: no more images)."""
        if self._closed or (self._next >= len(self.files) and not self.loop):
            return False
        if self._pacer is not None:
            self._pacer.wait_for(self._next)
        self._next += 1
        return True

    def retrieve(self, alloc: Alloc | None = None) -> CapturedFrame | None:
        """Read the image of the last slot grabbed (into ``alloc(shape)`` when given)."""
        if self._closed or self._next == 0:
            return None
        path = self.files[(self._next - 1) % len(self.files)]
        image = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if image is None:
            raise SourceError(f"camera {self.name}: cannot read image {path}")
        return CapturedFrame(self.name, self._next - 1, time.monotonic(), _into(_bgr(image), alloc))

    def read(self) -> CapturedFrame | None:
        return self.retrieve() if self.grab() else None

    def close(self) -> None:
        self._closed = True


class CameraSource:
    """A live camera: an OpenCV device index or a stream URL (rtsp://, http://)."""

    def __init__(self, name: str, device: int | str, *, open_timeout_s: float = 5.0) -> None:
        self.name = name
        self.device = device
        self._cap = cv2.VideoCapture(device)
        if not self._cap.isOpened():
            self._cap.release()
            raise SourceError(f"camera {name}: cannot open {device!r}")
        fps = float(self._cap.get(cv2.CAP_PROP_FPS) or 0.0)
        self._fps = fps if fps > 0 else None
        self._index = 0
        self._grabbed_s = 0.0
        self._timeout_s = open_timeout_s

    @property
    def nominal_fps(self) -> float | None:
        return self._fps

    def grab(self) -> bool:
        """Take the next frame from the device (blocks until it comes)."""
        if self._cap is None:
            return False
        if not self._cap.grab():
            raise SourceError(f"camera {self.name}: {self.device!r} stopped delivering frames")
        self._index += 1
        self._grabbed_s = time.monotonic()
        return True

    def retrieve(self, alloc: Alloc | None = None) -> CapturedFrame | None:
        if self._cap is None:
            return None
        ok, image = self._cap.retrieve()
        if not ok or image is None:
            raise SourceError(f"camera {self.name}: {self.device!r} delivered an unreadable frame")
        return CapturedFrame(self.name, self._index - 1, self._grabbed_s, _into(_bgr(image), alloc))

    def read(self) -> CapturedFrame | None:
        return self.retrieve() if self.grab() else None

    def close(self) -> None:
        if self._cap is not None:
            self._cap.release()
            self._cap = None


def _into(image: np.ndarray, alloc: Alloc | None) -> np.ndarray:
    """``image``, or a copy of it in the array ``alloc`` gives for its shape."""
    if alloc is None:
        return image
    out = alloc(image.shape)
    out[...] = image
    return out


def _bgr(image: np.ndarray) -> np.ndarray:
    if image.ndim == 2:
        return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    if image.shape[2] == 4:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
    return np.ascontiguousarray(image, dtype=np.uint8)


def probe_video(name: str, path: Path) -> tuple[tuple[int, int], float | None]:
    """((width, height), fps or None) of a video file; :class:`SourceError` when it does not open."""
    cap = cv2.VideoCapture(str(path))
    try:
        if not cap.isOpened():
            raise SourceError(f"camera {name}: cannot open video {path}")
        size = (int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)))
        fps = float(cap.get(cv2.CAP_PROP_FPS) or 0.0)
    finally:
        cap.release()
    if size[0] <= 0 or size[1] <= 0:
        raise SourceError(f"camera {name}: video {path} reports no frame size")
    return size, (fps if fps > 0 else None)
