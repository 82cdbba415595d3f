"""Camera videos of a take: one MP4 per view at the capture rate, written in the capture process.

The main process and each camera's capture worker share a :class:`VideoControl` (a few words and a
request text in shared memory, no pickles): :meth:`VideoControl.request` asks for a video (its
path, the take's start and length on the capture clock, the encoder's options), ``None`` ends it.
In the worker, :class:`VideoTap` looks at the control once per frame (one integer read), and hands
the frames to a :class:`VideoWriter` thread through a bounded queue: when the encoder falls
behind, the oldest frame is dropped and counted, so the capture loop (and detection behind it)
never waits for the video. The worker writes its state and counts back into the control.

The MP4 is H.264 (PyAV, libx264 by default) in fragments that start at each key frame (about
one a second), so a crash keeps every fragment written before it. Presentation times are the
take's clock: a frame captured ``t`` seconds after the take's start shows at ``t`` seconds.
:class:`VideoSession` is the main process's handle on every camera's control for one take.
"""

from __future__ import annotations

import ctypes
import json
import logging
import math
import threading
import time
from collections import deque
from dataclasses import asdict, dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.takes.config import TakesConfig

log = logging.getLogger(__name__)

REQUEST_BYTES = 4096
ERROR_BYTES = 512
# the control's words
_GEN, _SEEN, _STATE, _WRITTEN, _DROPPED, _REQ_LEN, _ERR_LEN, _FILES = range(8)
STATES = ("idle", "recording", "closed", "error")
_IDLE, _RECORDING, _CLOSED, _ERROR = range(4)


@dataclass(frozen=True, slots=True)
class VideoRequest:
    """What one camera's video is asked to be.

    path: the MP4 to write (its folder is made); t0_s: the take's start on the capture clock
    (``time.monotonic()``, the same in every process); duration_s: frames captured at or after
    ``t0_s + duration_s`` are not written (None: until stopped). codec/preset/crf: the encoder's;
    long_side: scale frames down to this many pixels on their long side (None: as captured);
    queue_frames: frames held for the encoder (the oldest is dropped when full); threads: the
    encoder's threads.
    """

    path: str
    t0_s: float
    duration_s: float | None = None
    fps: float = 30.0
    codec: str = "libx264"
    preset: str = "ultrafast"
    crf: int = 23
    long_side: int | None = None
    queue_frames: int = 16
    threads: int = 1

    def __post_init__(self) -> None:
        if not self.path:
            raise InputError("a video request needs a path")
        if not 1 <= self.queue_frames <= 600:
            raise InputError(f"video queue_frames must be in [1, 600], got {self.queue_frames}")
        if not 0 <= self.crf <= 51:
            raise InputError(f"video crf must be in [0, 51], got {self.crf}")
        if self.long_side is not None and not 64 <= self.long_side <= 8192:
            raise InputError(f"video long_side must be in [64, 8192] pixels, got {self.long_side}")
        if not 0 < self.fps <= 1000:
            raise InputError(f"video fps must be in (0, 1000], got {self.fps}")


@dataclass(frozen=True, slots=True)
class VideoStats:
    """One camera's video as its worker reports it: state (idle, recording, closed, error), frames
    written to the MP4 and dropped (the encoder was behind), the error if any, files written."""

    state: str
    written: int
    dropped: int
    error: str | None = None
    files: int = 0

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


class VideoControl:
    """One camera's video switch, shared by the main process and its capture worker.

    Made with :meth:`create` from the pipeline's multiprocessing context before the worker starts,
    and handed to it as an argument (shared memory travels to a child at its start).
    """

    def __init__(self, words: Any, request_text: Any, error_text: Any) -> None:
        self._words = words
        self._request = request_text
        self._error = error_text

    @classmethod
    def create(cls, ctx: Any) -> VideoControl:
        return cls(ctx.RawArray(ctypes.c_int64, 8), ctx.RawArray(ctypes.c_char, REQUEST_BYTES),
                   ctx.RawArray(ctypes.c_char, ERROR_BYTES))

    # ------------------------------------------------------------------------ the main process
    def request(self, req: VideoRequest | None) -> int:
        """Ask for ``req`` (None: stop); returns the request's generation (for :meth:`wait`)."""
        data = b"" if req is None else json.dumps(asdict(req)).encode("utf-8")
        if len(data) > REQUEST_BYTES:
            raise InputError(f"the video request is too long ({len(data)} bytes)")
        self._request[: len(data)] = data
        self._words[_REQ_LEN] = len(data)
        self._words[_GEN] = self._words[_GEN] + 1  # last: the worker reads the text after it sees this
        return int(self._words[_GEN])

    def stats(self) -> VideoStats:
        w = self._words
        err = bytes(self._error[: int(w[_ERR_LEN])]).decode("utf-8", "replace") if w[_ERR_LEN] else None
        state = int(w[_STATE])
        return VideoStats(STATES[state] if 0 <= state < len(STATES) else "error", int(w[_WRITTEN]),
                          int(w[_DROPPED]), err, int(w[_FILES]))

    def wait(self, generation: int, timeout_s: float) -> bool:
        """Whether the worker acted on ``generation`` and (for a stop) closed its file in time."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self._words[_SEEN] >= generation and self._words[_STATE] != _RECORDING:
                return True
            time.sleep(0.02)
        return False

    # ----------------------------------------------------------------------------- the worker
    @property
    def generation(self) -> int:
        return int(self._words[_GEN])

    def read_request(self) -> tuple[int, VideoRequest | None] | None:
        """(generation, request) as last asked; None when it changed while being read (ask again)."""
        gen = int(self._words[_GEN])
        n = int(self._words[_REQ_LEN])
        data = bytes(self._request[:n]) if n else b""
        if int(self._words[_GEN]) != gen:
            return None
        if not data:
            return gen, None
        try:
            return gen, VideoRequest(**json.loads(data))
        except (ValueError, TypeError):
            return None  # torn by a write in between: the generation moved, read it again

    def acknowledge(self, generation: int) -> None:
        self._words[_SEEN] = generation

    def report(self, state: int | None = None, *, written: int | None = None, dropped: int | None = None,
               error: str | None = None, files: int | None = None) -> None:
        w = self._words
        if written is not None:
            w[_WRITTEN] = written
        if dropped is not None:
            w[_DROPPED] = dropped
        if files is not None:
            w[_FILES] = files
        if error is not None:
            data = error.encode("utf-8")[:ERROR_BYTES]
            self._error[: len(data)] = data
            w[_ERR_LEN] = len(data)
        if state is not None:
            w[_STATE] = state


# ------------------------------------------------------------------------------ in the worker
class VideoWriter:
    """A thread that encodes the frames it is given into one MP4 (see the module docstring)."""

    def __init__(self, req: VideoRequest, camera: str, control: VideoControl, counts: list[int],
                 after: threading.Thread | None = None) -> None:
        self.req = req
        self.camera = camera
        self._control = control
        self._counts = counts  # [written, dropped, files]: shared by this camera's writers in turn
        self._frames: deque[tuple[NDArray[np.uint8], float]] = deque(maxlen=req.queue_frames)
        self._cv = threading.Condition()
        self._closing = False
        self._after = after
        self.thread = threading.Thread(target=self._run, name=f"video-{camera}", daemon=True)
        self.thread.start()

    def offer(self, image: NDArray[np.uint8], timestamp_s: float, owned: bool) -> None:
        """Queue a frame (copied unless ``owned``); never waits. Frames outside the take are skipped."""
        t = timestamp_s - self.req.t0_s
        if t < 0 or (self.req.duration_s is not None and t >= self.req.duration_s):
            return
        with self._cv:
            if self._closing:
                return
            if len(self._frames) == self._frames.maxlen:
                self._counts[1] += 1  # the deque drops the oldest
            self._frames.append((image if owned else image.copy(), t))
            self._cv.notify()

    def close(self) -> None:
        """Finish the file with what is queued (in the writer's thread; returns at once)."""
        with self._cv:
            self._closing = True
            self._cv.notify()

    def _report(self, state: int | None = None, error: str | None = None) -> None:
        self._control.report(state, written=self._counts[0], dropped=self._counts[1], files=self._counts[2],
                             error=error)

    def _run(self) -> None:
        if self._after is not None:
            self._after.join()  # the previous file of this camera is finished first
        out: Any = None
        stream: Any = None
        last_pts = -1
        try:
            import av

            while True:
                with self._cv:
                    while not self._frames and not self._closing:
                        self._cv.wait(0.5)
                    if not self._frames and self._closing:
                        break
                    image, t = self._frames.popleft()
                if out is None:
                    out, stream = self._open(av, image)
                pts = round(t * 1000)  # ms
                if self.req.duration_s is not None:  # rounding must not carry a frame to the take's end
                    pts = min(pts, math.ceil(self.req.duration_s * 1000) - 1)
                if pts <= last_pts:
                    continue
                last_pts = pts
                frame = self._frame(av, image, stream)
                frame.pts = pts
                frame.time_base = Fraction(1, 1000)
                for packet in stream.encode(frame):
                    out.mux(packet)
                self._counts[0] += 1
                if self._counts[0] % 15 == 0:
                    self._report()
            if out is not None:
                for packet in stream.encode():
                    out.mux(packet)
            self._close(out)
            out = None
            self._report(_CLOSED)
        except Exception as exc:  # the thread's boundary: the capture goes on without its video
            log.exception("camera %s: writing %s failed", self.camera, self.req.path)
            self._close(out)
            self._report(_ERROR, f"camera {self.camera}: writing the video failed: {exc}")

    def _close(self, out: Any) -> None:
        if out is not None:
            try:
                out.close()
            except Exception:
                log.exception("camera %s: closing %s failed", self.camera, self.req.path)

    def _size(self, image: NDArray[np.uint8]) -> tuple[int, int, int, int]:
        """(width, height) captured and (width, height) written (even, scaled to long_side)."""
        h, w = (image.shape[0] * 2 // 3, image.shape[1]) if image.ndim == 2 else image.shape[:2]
        ow, oh = w, h
        if self.req.long_side is not None and max(w, h) > self.req.long_side:
            s = self.req.long_side / max(w, h)
            ow, oh = round(w * s), round(h * s)
        return w, h, ow - ow % 2, oh - oh % 2

    def _open(self, av: Any, image: NDArray[np.uint8]) -> tuple[Any, Any]:
        path = _free_path(Path(self.req.path))
        path.parent.mkdir(parents=True, exist_ok=True)
        _, _, ow, oh = self._size(image)
        out = av.open(str(path), "w", format="mp4",
                      options={"movflags": "frag_keyframe+empty_moov+default_base_moof+delay_moov",
                               "use_editlist": "1",  # the edit list keeps the first frame's time
                               "flush_packets": "1"})  # each fragment reaches the file as it ends
        stream = out.add_stream(self.req.codec, rate=Fraction(self.req.fps).limit_denominator(1001))
        stream.width, stream.height, stream.pix_fmt = ow, oh, "yuv420p"
        stream.codec_context.time_base = Fraction(1, 1000)
        stream.thread_count = self.req.threads
        gop = max(1, round(self.req.fps))  # a key frame (and a fragment) about every second
        stream.options = {"preset": self.req.preset, "tune": "zerolatency", "crf": str(self.req.crf),
                          "g": str(gop), "keyint_min": str(gop)}
        self._counts[2] += 1
        self._report(_RECORDING)
        log.info("camera %s: recording %s (%dx%d)", self.camera, path, ow, oh)
        return out, stream

    def _frame(self, av: Any, image: NDArray[np.uint8], stream: Any) -> Any:
        w, h, ow, oh = self._size(image)
        if image.ndim == 2:  # I420 from a video decoder
            if w % 2 or h % 2:
                raise InputError(f"an I420 frame needs an even size, got {w}x{h}")
            frame = av.VideoFrame.from_ndarray(image, format="yuv420p")
        else:
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image[:, :, :3]), format="bgr24")
        if (ow, oh) != (w, h) or frame.format.name != "yuv420p":
            frame = frame.reformat(width=ow, height=oh, format="yuv420p", interpolation="FAST_BILINEAR")
        return frame


def _free_path(path: Path) -> Path:
    """``path``, or ``name-2.mp4``... when it exists (a capture worker restarted mid-take)."""
    if not path.exists():
        return path
    k = 2
    while path.with_name(f"{path.stem}-{k}{path.suffix}").exists():
        k += 1
    return path.with_name(f"{path.stem}-{k}{path.suffix}")


class VideoTap:
    """The capture loop's side: is a video wanted (:meth:`active`), and take its frames (:meth:`offer`)."""

    def __init__(self, control: VideoControl, camera: str) -> None:
        self.control = control
        self.camera = camera
        self._gen = 0
        self._writer: VideoWriter | None = None
        self._counts = [0, 0, 0]

    def active(self) -> bool:
        """Whether frames are wanted now; switches the writer when the main process asked."""
        if self.control.generation != self._gen:
            got = self.control.read_request()
            if got is not None:
                self._switch(*got)
        return self._writer is not None

    def _switch(self, gen: int, req: VideoRequest | None) -> None:
        previous = self._writer
        if previous is not None:
            previous.close()
        self._writer = None
        if req is not None:
            self._counts = [0, 0, 0]
            self.control.report(_RECORDING, written=0, dropped=0, files=0)
            self._writer = VideoWriter(req, self.camera, self.control, self._counts,
                                       after=previous.thread if previous is not None else None)
        elif previous is None:
            self.control.report(_IDLE)
        self._gen = gen
        self.control.acknowledge(gen)

    def offer(self, image: NDArray[np.uint8], timestamp_s: float, owned: bool = False) -> None:
        if self._writer is not None:
            self._writer.offer(image, timestamp_s, owned)

    def close(self, timeout_s: float = 10.0) -> None:
        """The capture ends: finish the file being written."""
        writer, self._writer = self._writer, None
        if writer is not None:
            writer.close()
            writer.thread.join(timeout_s)


# ----------------------------------------------------------------------- the main process's side
class VideoSession:
    """One take's videos: every camera's control asked at :meth:`start`, told to stop at :meth:`stop`.

    controls: camera -> (its control, its capture rate), as ``Pipeline.video_controls()`` gives them.
    """

    def __init__(self, controls: dict[str, tuple[VideoControl, float]], folder: Path,
                 config: TakesConfig | None = None) -> None:
        if not controls:
            raise InputError("no camera can record a video (the simulator has no images)")
        self.controls = {cam: control for cam, (control, _fps) in controls.items()}
        self._fps = {cam: fps for cam, (_control, fps) in controls.items()}
        self.folder = Path(folder)
        self.config = config or TakesConfig()

    def start(self, t0_s: float, duration_s: float | None = None) -> None:
        c = self.config
        for cam, control in self.controls.items():
            control.request(VideoRequest(
                str(self.folder / f"{cam}.mp4"), t0_s, duration_s, fps=self._fps.get(cam) or 30.0,
                codec=c.video_codec, preset=c.video_preset, crf=c.video_crf, long_side=c.video_long_side,
                queue_frames=c.video_queue_frames, threads=c.video_threads))

    def stop(self, timeout_s: float | None = None) -> dict[str, dict[str, Any]]:
        """End every camera's video; each camera's figures (``state`` ``no answer`` when its worker
        did not finish the file within ``timeout_s``, default ``video_stop_timeout_s``)."""
        gens = {cam: control.request(None) for cam, control in self.controls.items()}
        deadline = time.monotonic() + (self.config.video_stop_timeout_s if timeout_s is None else timeout_s)
        out: dict[str, dict[str, Any]] = {}
        for cam, control in self.controls.items():
            done = control.wait(gens[cam], max(0.0, deadline - time.monotonic()))
            stats = control.stats().as_dict()
            if not done:
                stats["state"] = "no answer"
            out[cam] = stats
        return out

    def stats(self) -> dict[str, dict[str, Any]]:
        return {cam: control.stats().as_dict() for cam, control in self.controls.items()}
