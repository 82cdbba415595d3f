"""Shared-memory ring buffers for camera frames (no pickled arrays between processes).

One ring per camera: ``slots`` fixed-size slots of ``capacity_bytes`` each, behind a
small int64/float64 header. The capture process is the only writer; readers take the
newest complete frame. A slot's sequence number is set to -1 while it is written and
to the frame's sequence number after, so a reader that copied a slot while the
writer lapped it sees the mismatch and drops the copy (a seqlock).

The main process creates (and finally unlinks) every segment; workers attach with
:meth:`FrameRing.attach`, which keeps them out of Python's resource tracker so a
worker's exit never unlinks a segment that the others still use. A worker whose main
process died unlinks the segments it attached (:func:`unlink_attached`).
"""

from __future__ import annotations

import contextlib
import logging
import secrets
import time
from collections.abc import Iterable
from dataclasses import dataclass
from multiprocessing import resource_tracker, shared_memory
from pathlib import Path

try:
    import _posixshmem
except ImportError:  # not a POSIX system
    _posixshmem = None

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import SourceError

SHM_PREFIX = "cavewalk_"  # /dev/shm names of the camera rings
MAILBOX_PREFIX = "cwbox_"  # ... of the mailboxes between the stages
STREAM_PREFIX = "cwstream_"  # ... of the stream book (the emitter's shared sequence)
PREFIXES = (SHM_PREFIX, MAILBOX_PREFIX, STREAM_PREFIX)
log = logging.getLogger(__name__)
_attached: set[str] = set()  # segments this process attached to (for unlink_attached)
_GLOBAL_WORDS = 2  # [latest seq, reader's demand time (float64 bits)]
_SLOT_WORDS = 8  # [seq, ts (float64 bits), rows, width, channels (0: a 2-D image), frame index, nbytes,
#                  reserved]


@dataclass(frozen=True, slots=True)
class RingSpec:
    """What a process needs to attach to a ring (small and picklable)."""

    shm_name: str
    slots: int
    capacity_bytes: int

    def __post_init__(self) -> None:
        if self.slots < 2:
            raise ValueError(f"a ring needs >= 2 slots, got {self.slots}")
        if self.capacity_bytes <= 0:
            raise ValueError(f"capacity_bytes must be > 0, got {self.capacity_bytes}")

    @property
    def header_bytes(self) -> int:
        return 8 * (_GLOBAL_WORDS + _SLOT_WORDS * self.slots)

    @property
    def total_bytes(self) -> int:
        return self.header_bytes + self.slots * self.capacity_bytes


@dataclass(frozen=True, slots=True)
class SlotFrame:
    """A frame read from a ring: its sequence number, capture time, camera frame index and pixels."""

    seq: int
    timestamp_s: float
    index: int
    image: NDArray[np.uint8]


class FrameRing:
    """A ring of frames in one shared-memory segment."""

    def __init__(self, spec: RingSpec, shm: shared_memory.SharedMemory, owner: bool) -> None:
        self.spec = spec
        self._shm = shm
        self.owner = owner
        self._buf: memoryview = shm.buf  # type: ignore[assignment]
        self._words = np.ndarray(
            (_GLOBAL_WORDS + _SLOT_WORDS * spec.slots,), dtype=np.int64, buffer=self._buf[: spec.header_bytes]
        )
        self._ts = self._words.view(np.float64)

    @classmethod
    def create(cls, slots: int, capacity_bytes: int, tag: str = "", prefix: str = SHM_PREFIX) -> FrameRing:
        """A new, empty ring (the caller owns it and must :meth:`unlink` it)."""
        safe = "".join(ch for ch in tag if ch.isalnum())[:12]
        name = f"{prefix}{safe}_{secrets.token_hex(4)}"
        spec = RingSpec(name, slots, capacity_bytes)
        shm = shared_memory.SharedMemory(name=name, create=True, size=spec.total_bytes)
        ring = cls(spec, shm, owner=True)
        ring._words[:] = 0
        ring._words[0] = -1
        ring._ts[1] = 0.0
        ring._words[_GLOBAL_WORDS::_SLOT_WORDS] = -1
        return ring

    @classmethod
    def attach(cls, spec: RingSpec) -> FrameRing:
        """Attach to an existing ring without registering it with the resource tracker."""
        return cls(spec, attach_segment(spec.shm_name), owner=False)

    def _slot_base(self, slot: int) -> int:
        return _GLOBAL_WORDS + _SLOT_WORDS * slot

    def _data(self, slot: int, nbytes: int) -> NDArray[np.uint8]:
        start = self.spec.header_bytes + slot * self.spec.capacity_bytes
        return np.ndarray((nbytes,), dtype=np.uint8, buffer=self._buf[start : start + nbytes])

    @property
    def demand_s(self) -> float:
        """When the reader next wants a frame (``time.monotonic()``; 0 = always)."""
        return float(self._ts[1])

    def set_demand(self, when_s: float) -> None:
        """The reader tells the writer when it will next take a frame (the dynamic frame rate)."""
        self._ts[1] = float(when_s)

    @property
    def latest_seq(self) -> int:
        """Sequence number of the newest complete frame (-1 before the first)."""
        return int(self._words[0])

    def claim(self, shape: tuple[int, ...]) -> NDArray[np.uint8]:
        """The next slot as a writable (H, W, C) or (H, W) uint8 view, marked as being written:
        fill it, then :meth:`publish` (a claim never published leaves the slot empty, and the
        next claim takes it again). A decoder writes its frame straight into shared memory."""
        if len(shape) not in (2, 3):
            raise ValueError(f"frames must be (H, W, C) or (H, W) uint8, got shape {shape}")
        nbytes = int(np.prod(shape))
        if nbytes > self.spec.capacity_bytes:
            raise SourceError(
                f"frame of {shape} ({nbytes} bytes) exceeds the ring's slot "
                f"capacity of {self.spec.capacity_bytes} bytes"
            )
        slot = (self.latest_seq + 1) % self.spec.slots
        self._words[self._slot_base(slot)] = -1
        return self._data(slot, nbytes).reshape(shape)

    def publish(self, shape: tuple[int, ...], timestamp_s: float, index: int) -> int:
        """Make the claimed slot (filled with a frame of ``shape``) the newest frame; returns its seq."""
        seq = self.latest_seq + 1
        base = self._slot_base(seq % self.spec.slots)
        h, w, c = shape if len(shape) == 3 else (*shape, 0)
        self._ts[base + 1] = timestamp_s
        self._words[base + 2 : base + 7] = (h, w, c, index, int(np.prod(shape)))
        self._words[base] = seq
        self._words[0] = seq
        return seq

    def write(self, image: NDArray[np.uint8], timestamp_s: float, index: int) -> int:
        """Store a frame (H, W, C) or 2-D (an I420 image) in the next slot; returns its sequence number."""
        if image.dtype != np.uint8 or image.ndim not in (2, 3):
            raise ValueError(f"frames must be (H, W, C) or (H, W) uint8, got {image.shape} {image.dtype}")
        self.claim(image.shape)[...] = image
        return self.publish(image.shape, timestamp_s, index)

    def timestamp_of(self, seq: int) -> float | None:
        """Capture time of frame ``seq`` from the header (None if not in the ring)."""
        base = self._slot_base(seq % self.spec.slots)
        if int(self._words[base]) != seq:
            return None
        ts = float(self._ts[base + 1])
        return ts if int(self._words[base]) == seq else None

    def read_latest(self, after_seq: int = -1, out: NDArray[np.uint8] | None = None) -> SlotFrame | None:
        """A copy of the newest frame if it is newer than ``after_seq``, else None (``out``: see
        :meth:`read_seq`)."""
        for _ in range(3):
            seq = self.latest_seq
            if seq < 0 or seq <= after_seq:
                return None
            frame = self.read_seq(seq, out)
            if frame is not None:
                return frame
        return None

    def read_seq(self, seq: int, out: NDArray[np.uint8] | None = None) -> SlotFrame | None:
        """A copy of frame ``seq`` if it is still in the ring and intact, else None.

        out: a buffer of at least the frame's bytes to copy into (the image is a view of it),
        so a reader that keeps one per camera does not pay for fresh pages every frame.
        """
        slot = seq % self.spec.slots
        base = self._slot_base(slot)
        if int(self._words[base]) != seq:
            return None
        ts = float(self._ts[base + 1])
        h, w, c, index, nbytes = (int(v) for v in self._words[base + 2 : base + 7])
        if out is not None and out.nbytes >= nbytes:
            flat = out.reshape(-1)[:nbytes]
            np.copyto(flat, self._data(slot, nbytes))
        else:
            flat = self._data(slot, nbytes).copy()
        if int(self._words[base]) != seq:  # overwritten while copying
            return None
        return SlotFrame(seq, ts, index, flat.reshape((h, w, c) if c else (h, w)))

    def close(self) -> None:
        """Detach (every process); the owner also unlinks with :meth:`unlink`."""
        self._words = None  # type: ignore[assignment]
        self._ts = None  # type: ignore[assignment]
        self._buf = None  # type: ignore[assignment]
        with contextlib.suppress(BufferError):  # a view still alive; the mapping goes with the process
            self._shm.close()

    def unlink(self) -> None:
        """Remove the segment (owner only; safe to call twice)."""
        self.close()
        with contextlib.suppress(FileNotFoundError):
            self._shm.unlink()


def attach_segment(name: str) -> shared_memory.SharedMemory:
    """Attach to an existing segment without registering it with the resource tracker (so this
    process's exit never unlinks it); remembered for :func:`unlink_attached`."""
    original = resource_tracker.register
    resource_tracker.register = lambda *a, **k: None  # type: ignore[assignment]
    try:
        shm = shared_memory.SharedMemory(name=name, create=False)
    except FileNotFoundError as exc:
        raise SourceError(f"shared-memory segment {name} does not exist") from exc
    finally:
        resource_tracker.register = original  # type: ignore[assignment]
    _attached.add(name)
    return shm


def unlink_attached() -> list[str]:
    """Remove every segment this process attached to (a worker whose main process died: nobody
    else will). Bypasses the resource tracker, which never knew of them. Returns the names."""
    removed = []
    for name in sorted(_attached):
        if _posixshmem is None:
            break
        with contextlib.suppress(OSError):
            _posixshmem.shm_unlink("/" + name)
            removed.append(name)
    _attached.clear()
    return removed


def mapped_segments(proc_dir: Path = Path("/proc"), pids: Iterable[int] | None = None) -> set[str]:
    """The /dev/shm names that some live process maps (``/proc/*/maps``), or one of ``pids``."""
    mapped: set[str] = set()
    files = proc_dir.glob("[0-9]*/maps") if pids is None else (proc_dir / str(p) / "maps" for p in pids)
    for maps in files:
        with contextlib.suppress(OSError):
            for line in maps.read_text(errors="replace").splitlines():
                if "/dev/shm/" in line:
                    mapped.add(line.rsplit("/dev/shm/", 1)[1].split(" ")[0])
    return mapped


def sweep_stale_segments(
    shm_dir: Path = Path("/dev/shm"), proc_dir: Path = Path("/proc"), settle_s: float = 0.2
) -> list[str]:
    """Remove cavewalk's segments that a crash left behind: named with one of :data:`PREFIXES` and
    mapped by no live process in two looks ``settle_s`` apart (a process creating a segment maps
    it within microseconds). A server killed with its workers and the resource tracker (``kill -9``
    of the process group, the OOM killer) leaves 16 MB of mailboxes a run, which nothing else
    would remove before a reboot. Returns the names removed; nothing on a system without these
    folders."""
    if _posixshmem is None or not shm_dir.is_dir() or not proc_dir.is_dir():
        return []
    candidates = {p.name for p in shm_dir.iterdir() if p.name.startswith(PREFIXES)}
    if not candidates:
        return []
    stale = candidates - mapped_segments(proc_dir)
    if stale:
        time.sleep(settle_s)
        stale -= mapped_segments(proc_dir)
    removed = []
    for name in sorted(stale):
        with contextlib.suppress(OSError):
            _posixshmem.shm_unlink("/" + name)
            removed.append(name)
    if removed:
        log.warning(
            "removed %d shared-memory segments left behind by a crashed run (%s)",
            len(removed), ", ".join(removed[:6]) + (", ..." if len(removed) > 6 else ""),
        )  # fmt: skip
    return removed
