"""A newest-message mailbox between two processes that either may be killed at any moment.

The stages hand on their results (``DetectedFrame``, ``FusedFrame``) through one of these,
not through a ``multiprocessing.Queue``: a queue guards its pipe with process-shared
locks, and a worker killed while it held one (a reader waiting in ``get(timeout)`` holds
the queue's read lock all the while) leaves the queue jammed for whoever replaces it.
A mailbox has no lock: the message is pickled into a slot of a shared-memory ring
(:class:`pipeline.runtime.shm.FrameRing`, a seqlock with one writer), and a byte on a
non-blocking pipe wakes the reader. A writer killed mid-message leaves the slot marked
as being written, which no reader takes; a restarted writer or reader goes on where the
dead one stopped. The reader always gets the newest message (older ones are counted as
skipped), which is what every stage wants.

The main process creates it (:meth:`Mailbox.create`) and unlinks it (:meth:`Mailbox.unlink`);
workers get its :class:`MailboxSpec`.
"""

from __future__ import annotations

import contextlib
import multiprocessing.connection as mpc
import os
import pickle
import time
from dataclasses import dataclass

import numpy as np

from pipeline.runtime.shm import MAILBOX_PREFIX, FrameRing, RingSpec

SLOTS = 4
CAPACITY_BYTES = 2 * 1024 * 1024  # the largest pickled message (a few people in a few views: ~50 kB)


@dataclass(frozen=True)
class MailboxSpec:
    """What a process needs to use a mailbox (picklable: the pipe ends travel to the child)."""

    ring: RingSpec
    wake_r: mpc.Connection  # read end
    wake_w: mpc.Connection  # write end


class Mailbox:
    """One writer puts, one reader takes the newest; see the module docstring."""

    def __init__(self, spec: MailboxSpec, ring: FrameRing) -> None:
        self.spec = spec
        self._ring = ring
        self._last_seq = ring.latest_seq  # a restarted reader does not take the last message again
        self._w_set = False

    @classmethod
    def create(cls, tag: str, slots: int = SLOTS, capacity_bytes: int = CAPACITY_BYTES) -> Mailbox:
        ring = FrameRing.create(slots, capacity_bytes, tag, prefix=MAILBOX_PREFIX)
        wake_r, wake_w = mpc.Pipe(duplex=False)
        return cls(MailboxSpec(ring.spec, wake_r, wake_w), ring)

    @classmethod
    def attach(cls, spec: MailboxSpec) -> Mailbox:
        return cls(spec, FrameRing.attach(spec.ring))

    def put(self, message: object) -> None:
        """Publish ``message`` (replaces what the reader has not taken yet)."""
        data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
        arr = np.frombuffer(data, dtype=np.uint8).reshape(1, -1)
        self._ring.write(arr, time.monotonic(), 0)
        fd = self.spec.wake_w.fileno()
        if not self._w_set:
            os.set_blocking(fd, False)
            self._w_set = True
        with contextlib.suppress(BlockingIOError, BrokenPipeError, InterruptedError):
            os.write(fd, b"\x01")

    def get(self, timeout: float) -> tuple[object, int] | None:
        """(the newest message not taken yet, how many older ones it skipped), or None after ``timeout``.
        The reader checks what it got (``isinstance``): a message is whatever was unpickled."""
        for _ in range(3):  # the writer may lap the slot being read; try the newer one
            if not self.get_wait(timeout):
                return None
            slot = self._ring.read_latest(self._last_seq)
            if slot is not None:
                skipped = max(0, slot.seq - self._last_seq - 1) if self._last_seq >= 0 else 0
                self._last_seq = slot.seq
                return pickle.loads(slot.image.tobytes()), skipped
        return None

    def get_all(self, timeout: float) -> list[object]:
        """Every message not taken yet that the ring still holds (oldest first; the newest ``SLOTS``
        at most), waiting up to ``timeout`` s for one: for a reader that must see each (events)."""
        if not self.get_wait(timeout):
            return []
        out = []
        latest = self._ring.latest_seq
        for seq in range(max(self._last_seq + 1, latest - self.spec.ring.slots + 1), latest + 1):
            slot = self._ring.read_seq(seq)
            if slot is not None:
                out.append(pickle.loads(slot.image.tobytes()))
        self._last_seq = max(self._last_seq, latest)
        return out

    def get_wait(self, timeout: float) -> bool:
        """Wait up to ``timeout`` s for a message not taken yet; whether one is there."""
        deadline = time.monotonic() + timeout
        while self._ring.latest_seq <= self._last_seq:
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            if mpc.wait([self.spec.wake_r], min(left, 0.05)):
                with contextlib.suppress(BlockingIOError, OSError):
                    os.read(self.spec.wake_r.fileno(), 4096)
        return True

    def close(self) -> None:
        self._ring.close()

    def unlink(self) -> None:
        """Remove the segment and close the pipe (the creator, at the end of a run)."""
        self._ring.unlink()
        for conn in (self.spec.wake_r, self.spec.wake_w):
            with contextlib.suppress(OSError):
                conn.close()
