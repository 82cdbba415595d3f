"""Recording a take from the running pipeline: a sink with ``on_result(FrameResult)``.

:meth:`TakeRecorder.on_result` is called by the pipeline for every fused frame; it only appends to
a bounded deque (the oldest frame is dropped and counted when full, so recording never blocks the
pipeline). A writer thread turns the frames into ``frames.jsonl`` lines on the take's clock
(``t`` = seconds since the take started, ``ts`` = Unix time) and gets them to the disk at least
every ``flush_interval_s`` (fsync), so a crash loses at most that much. The take stops when told,
or by itself once its duration has passed; then :func:`~pipeline.takes.files.finish_take` builds
the skeletons and the checksums. With ``videos``, the capture workers write one MP4 per camera
into ``videos/`` from the take's start to its end (:mod:`pipeline.takes.video`); the manifest's
``videos`` gives each camera's frames written and dropped.
"""

from __future__ import annotations

import json
import logging
import os
import threading
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

from pipeline.errors import InputError
from pipeline.results import FrameResult, frame_record
from pipeline.takes.config import TakesConfig
from pipeline.takes.files import CALIBRATION, FRAMES, MANIFEST, finish_take, write_json, write_spans
from pipeline.takes.protocol import LabelSpan, Protocol, Step
from pipeline.takes.video import VideoSession

log = logging.getLogger(__name__)

#: The longest a take waits after its end for frames captured before it (they lag by the pipeline's
#: latency); the first frame captured after the end ends it at once.
END_GRACE_S = 2.0


class TakeRecorder:
    """Writes one take into ``folder`` (which must not exist yet) as the frames come."""

    def __init__(
        self,
        folder: Path,
        manifest: dict[str, Any],
        config: TakesConfig | None = None,
        *,
        protocol: Protocol | None = None,
        spans: list[LabelSpan] | None = None,
        duration_s: float | None = None,
        calibration: dict[str, Any] | None = None,
        on_done: Callable[[dict[str, Any]], None] | None = None,
        clock: Callable[[], float] = time.monotonic,
        videos: VideoSession | None = None,
    ) -> None:
        self.folder = Path(folder)
        self.config = config or TakesConfig()
        self.protocol = protocol
        if duration_s is None and protocol is not None:
            duration_s = protocol.duration_s
        if duration_s is not None and not (0 < duration_s <= self.config.max_duration_s):
            raise InputError(f"duration must be in (0, {self.config.max_duration_s:g}] s, got {duration_s}")
        self.duration_s = duration_s
        self._manifest = dict(manifest)
        self._spans = list(spans or [])
        self._calibration = calibration
        self._on_done = on_done
        self._clock = clock
        self.videos = videos
        self._frames: deque[FrameResult] = deque(maxlen=self.config.queue_frames)
        self._cv = threading.Condition()
        self._stopping = False
        self._thread: threading.Thread | None = None
        self._file: IO[bytes] | None = None
        self._final: dict[str, Any] | None = None
        self._done = threading.Event()
        self.t0 = 0.0
        self.t0_unix = 0.0
        self.written = 0
        self.dropped = 0
        self.error: str | None = None
        self._past_end = False

    # ------------------------------------------------------------------------------ lifecycle
    def start(self) -> None:
        if self.folder.exists():
            raise InputError(f"take folder already exists: {self.folder}")
        self.folder.mkdir(parents=True)
        self.t0, self.t0_unix = self._clock(), time.time()
        self._manifest.update(
            {
                "complete": False,
                "status": "recording",
                "start_unix": self.t0_unix,
                "planned_duration_s": self.duration_s,
                "protocol": self.protocol.to_dict() if self.protocol is not None else None,
                "files": {},
            }
        )
        if self._calibration is not None:
            write_json(self.folder / CALIBRATION, self._calibration)
        if self._spans:
            write_spans(self.folder, self._spans)
        if self.videos is not None:
            self._manifest["videos"] = {cam: {"state": "recording"} for cam in self.videos.controls}
        write_json(self.folder / MANIFEST, self._manifest)
        self._file = (self.folder / FRAMES).open("ab")
        if self.videos is not None:  # the capture workers write videos/<camera>.mp4 on the take's clock
            self.videos.start(self.t0, self.duration_s)
        self._thread = threading.Thread(target=self._run, name=f"take-{self.folder.name}", daemon=True)
        self._thread.start()

    def on_result(self, result: FrameResult) -> None:
        """The pipeline's sink call: queue and return at once."""
        with self._cv:
            if self._stopping:
                return
            if len(self._frames) == self._frames.maxlen:
                self.dropped += 1  # the deque drops the oldest
            self._frames.append(result)
            self._cv.notify()

    def stop(self, timeout_s: float = 30.0) -> dict[str, Any]:
        """Write what came, finish the take (``complete``) and return its manifest."""
        with self._cv:
            self._stopping = True
            self._cv.notify()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout_s)
        self._done.wait(timeout_s)
        if self._final is None:
            raise RuntimeError(self.error or "the take did not finish")
        return self._final

    @property
    def done(self) -> bool:
        return self._done.is_set()

    def wait(self, timeout_s: float | None = None) -> bool:
        return self._done.wait(timeout_s)

    @property
    def manifest(self) -> dict[str, Any]:
        return dict(self._final if self._final is not None else self._manifest)

    def elapsed_s(self) -> float:
        return max(0.0, self._clock() - self.t0) if self.t0 else 0.0

    def prompt(self) -> tuple[int, Step, float] | None:
        """The protocol's current step, its index and the seconds left in it (None: none or over)."""
        if self.protocol is None or self.done or not self.t0:
            return None
        return self.protocol.step_at(self.elapsed_s())

    # ---------------------------------------------------------------------------- the writer
    def _run(self) -> None:
        cfg = self.config
        last_sync = self._clock()
        try:
            while True:
                with self._cv:
                    if not self._frames and not self._stopping:
                        self._cv.wait(0.1)
                    batch = list(self._frames)
                    self._frames.clear()
                    stopping = self._stopping
                # frames captured before the end still come through the pipeline: wait a moment for them
                over = self.duration_s is not None and (
                    self._past_end or self.elapsed_s() >= self.duration_s + END_GRACE_S
                )
                for result in batch:
                    self._write(result)
                now = self._clock()
                if now - last_sync >= cfg.flush_interval_s or stopping or over:
                    self._sync()
                    last_sync = now
                if stopping or over:
                    with self._cv:
                        self._stopping = True
                        leftover = list(self._frames)
                        self._frames.clear()
                    for result in leftover:
                        self._write(result)
                    break
        except Exception as exc:  # the loop boundary: the take keeps what reached the disk
            log.exception("writing take %s failed", self.folder.name)
            self.error = f"writing the take failed: {exc}"
        finally:
            self._close()

    def _write(self, result: FrameResult) -> None:
        t = result.timestamp_s - self.t0
        if t < 0:
            return  # captured before the take started
        if self.duration_s is not None and t >= self.duration_s:
            self._past_end = True  # every frame captured before the end has come (they come in order)
            return
        rec = frame_record(result)
        rec["t"] = round(t, 6)
        rec["ts"] = round(self.t0_unix + t, 6)
        if self._file is None:
            return
        self._file.write(json.dumps(rec, separators=(",", ":"), allow_nan=False).encode("utf-8") + b"\n")
        self.written += 1

    def _sync(self) -> None:
        if self._file is not None:
            self._file.flush()
            os.fsync(self._file.fileno())

    def _close(self) -> None:
        try:
            if self._file is not None:
                self._sync()
                self._file.close()
                self._file = None
            self._manifest["dropped_frames"] = self.dropped
            if self.videos is not None:  # the files are closed before their checksums are taken
                self._manifest["videos"] = self.videos.stop()
            if self.error:
                self._manifest["error"] = self.error
            self._final = finish_take(
                self.folder,
                complete=self.error is None,
                end_unix=self.t0_unix + self.elapsed_s(),
                manifest=self._manifest,
            )
        except Exception as exc:
            log.exception("finishing take %s failed", self.folder.name)
            self.error = self.error or f"finishing the take failed: {exc}"
        finally:
            self._done.set()
        if self._on_done is not None and self._final is not None:
            try:
                self._on_done(self._final)
            except Exception:
                log.exception("take %s: the done callback failed", self.folder.name)
