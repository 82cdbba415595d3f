"""Helpers of the runtime tests: small real videos, process and shared-memory checks, a UDP listener."""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import psutil

from pipeline.emitter import ReceiverStats, open_receiver_socket, receive
from pipeline.runtime.shm import PREFIXES, SHM_PREFIX, FrameRing, mapped_segments


def shrink_video(src: Path, dst: Path, frames: int, scale: float = 0.25) -> Path:
    """The first ``frames`` frames of a real video, scaled down (keeps the tests light on 2 cores)."""
    cap = cv2.VideoCapture(str(src))
    w = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH) * scale) // 2 * 2
    h = int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT) * scale) // 2 * 2
    out = cv2.VideoWriter(str(dst), cv2.VideoWriter_fourcc(*"mp4v"), 30.0, (w, h))
    for _ in range(frames):
        ok, img = cap.read()
        if not ok:
            break
        out.write(cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA))
    cap.release()
    out.release()
    return dst


def shm_segments(prefixes: str | tuple[str, ...] = SHM_PREFIX) -> set[str]:
    """cavewalk's /dev/shm segments (by default the camera rings)."""
    return {n for n in os.listdir("/dev/shm") if n.startswith(prefixes)}


def segments_of(root: int, prefixes: str | tuple[str, ...] = PREFIXES) -> set[str]:
    """cavewalk's /dev/shm segments that process ``root`` or one of its descendants maps now: one
    run's own, whatever other test processes (``pytest -n``) create and remove meanwhile."""
    pids = [root, *(p.pid for p in psutil.Process(root).children(recursive=True))]
    return {n for n in mapped_segments(pids=pids) if n.startswith(prefixes)}


class CreatedRings:
    """The /dev/shm names of every ring (camera ring, mailbox) this process creates while it is
    installed (:meth:`FrameRing.create`, spied on, still creates them): a test checks its own
    pipeline's segments, whatever other test processes create and remove meanwhile."""

    def __init__(self) -> None:
        self.names: list[str] = []

    def spy(self, create: Callable[..., FrameRing]) -> Callable[..., FrameRing]:
        def created(*args: Any, **kwargs: Any) -> FrameRing:
            ring = create(*args, **kwargs)
            self.names.append(ring.spec.shm_name)
            return ring

        return created

    def of(self, prefix: str) -> list[str]:
        return [n for n in self.names if n.startswith(prefix)]

    def existing(self) -> set[str]:
        """Those still in /dev/shm."""
        return {n for n in self.names if os.path.exists(f"/dev/shm/{n}")}


def children_alive(pids: list[int]) -> list[int]:
    alive = []
    for pid in pids:
        try:
            p = psutil.Process(pid)
            if p.status() != psutil.STATUS_ZOMBIE:
                alive.append(pid)
        except psutil.NoSuchProcess:
            pass
    return alive


def wait_for(cond: Callable[[], bool], timeout_s: float, what: str, poll_s: float = 0.1) -> None:
    deadline = time.monotonic() + timeout_s
    while not cond():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(poll_s)


class Listener:
    """The reference receiver on an ephemeral port of 127.0.0.1, in a thread."""

    def __init__(self) -> None:
        self.sock = open_receiver_socket(0, "127.0.0.1")
        self.port: int = self.sock.getsockname()[1]
        self.messages: list[dict[str, Any] | None] = []
        self.stats: ReceiverStats | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        self.stats = receive(self.sock, on_message=lambda m, _d: self.messages.append(m),
                             should_stop=self._stop.is_set)

    def of_type(self, kind: str) -> list[dict[str, Any]]:
        return [m for m in list(self.messages) if m is not None and m["type"] == kind]

    def close(self) -> ReceiverStats:
        self._stop.set()
        self._thread.join(timeout=2)
        self.sock.close()
        assert self.stats is not None
        return self.stats
