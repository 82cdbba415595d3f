"""Shared-memory frame rings: one writer, newest-frame readers, torn reads detected, no leftovers."""

from __future__ import annotations

import multiprocessing as mp
import os

import numpy as np
import pytest

from pipeline.errors import SourceError
from pipeline.runtime.shm import PREFIXES, FrameRing, RingSpec, sweep_stale_segments

from .live import shm_segments


def img(value: int, h: int = 6, w: int = 5) -> np.ndarray:
    return np.full((h, w, 3), value, np.uint8)


def test_write_then_read_newest() -> None:
    ring = FrameRing.create(3, 6 * 5 * 3, "t")
    try:
        assert ring.latest_seq == -1 and ring.read_latest() is None
        for i in range(5):
            assert ring.write(img(i), 10.0 + i, 100 + i) == i
        frame = ring.read_latest()
        assert frame is not None
        assert (frame.seq, frame.timestamp_s, frame.index) == (4, 14.0, 104)
        assert np.array_equal(frame.image, img(4))
        assert ring.read_latest(after_seq=4) is None, "nothing newer than seq 4"
        assert ring.read_seq(1) is None, "seq 1 was overwritten (3 slots)"
        assert ring.read_seq(2) is not None and ring.timestamp_of(3) == 13.0
    finally:
        ring.unlink()


def test_frames_of_other_sizes_fit_while_within_capacity() -> None:
    ring = FrameRing.create(2, 100 * 3, "t")
    try:
        ring.write(img(1, 10, 10), 0.0, 0)
        ring.write(img(2, 4, 20), 0.0, 1)
        frame = ring.read_latest()
        assert frame is not None and frame.image.shape == (4, 20, 3)
        with pytest.raises(SourceError, match="exceeds the ring's slot capacity"):
            ring.write(img(3, 11, 10), 0.0, 2)
        assert ring.latest_seq == 1, "a rejected frame leaves the ring unchanged"
        with pytest.raises(ValueError, match="must be \\(H, W, C\\) or \\(H, W\\) uint8"):
            ring.write(np.zeros((4, 4, 3), np.float32), 0.0, 3)
    finally:
        ring.unlink()


def test_a_2d_i420_frame_comes_back_2d() -> None:
    ring = FrameRing.create(2, 100 * 3, "t")
    try:
        yuv = np.arange(12 * 8, dtype=np.uint8).reshape(12, 8)  # an 8x8 I420 image
        ring.write(yuv, 1.5, 4)
        frame = ring.read_latest()
        assert frame is not None and frame.image.shape == (12, 8) and frame.index == 4
        np.testing.assert_array_equal(frame.image, yuv)
    finally:
        ring.unlink()


def test_a_slot_being_written_is_not_read() -> None:
    ring = FrameRing.create(2, 30 * 3, "t")
    try:
        ring.write(img(7), 0.0, 0)
        base = 2  # slot 0's header
        ring._words[base] = -1  # the writer's "being written" mark
        assert ring.read_seq(0) is None, "a torn slot must not be handed out"
    finally:
        ring.unlink()


def _reader(spec: RingSpec, out: mp.Queue) -> None:  # type: ignore[type-arg]
    ring = FrameRing.attach(spec)
    frame = ring.read_latest()
    out.put(None if frame is None else (frame.seq, int(frame.image[0, 0, 0]), frame.image.shape))
    ring.close()


def test_another_process_reads_the_frames_and_nothing_is_left() -> None:
    before = shm_segments()
    ring = FrameRing.create(3, 6 * 5 * 3, "proc")
    ring.write(img(42), 1.0, 0)
    ctx = mp.get_context("spawn")
    out = ctx.Queue()
    p = ctx.Process(target=_reader, args=(ring.spec, out))
    p.start()
    got = out.get(timeout=60)
    p.join(timeout=30)
    assert got == (0, 42, (6, 5, 3))
    assert p.exitcode == 0
    assert ring.spec.shm_name in shm_segments(), "a reader exiting must not unlink the owner's segment"
    ring.unlink()
    ring.unlink()  # twice is fine
    # only this test's own segments: other processes on a shared machine come and go in /dev/shm
    assert ring.spec.shm_name not in shm_segments(), "the segment is gone after unlink"
    assert not {n for n in shm_segments() - before if "proc" in n}, "no segment of this test left"


def test_attach_to_missing_ring() -> None:
    with pytest.raises(SourceError, match="does not exist"):
        FrameRing.attach(RingSpec("cavewalk_nonexistent_x", 2, 10))


@pytest.mark.parametrize(("slots", "capacity", "match"), [(1, 10, ">= 2 slots"), (2, 0, "capacity_bytes")])
def test_bad_ring_spec(slots: int, capacity: int, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        RingSpec("x", slots, capacity)


def test_reader_demand_is_shared_through_the_header() -> None:
    ring = FrameRing.create(2, 30, "t")
    try:
        reader = FrameRing.attach(ring.spec)
        assert ring.demand_s == 0.0, "a new ring wants every frame"
        reader.set_demand(123.5)
        assert ring.demand_s == 123.5, "the writer sees when the reader next wants a frame"
        ring.write(img(1, 2, 5), 1.0, 0)
        assert reader.demand_s == 123.5 and reader.latest_seq == 0, "writing leaves the demand alone"
        reader.close()
    finally:
        ring.unlink()


def _leftover(name: str) -> None:
    """A segment as a crashed run leaves it: created, mapped by nobody, unknown to any resource
    tracker (the tracker died with the run)."""
    from multiprocessing import resource_tracker, shared_memory

    shm = shared_memory.SharedMemory(name=name, create=True, size=4096)
    resource_tracker.unregister(shm._name, "shared_memory")  # type: ignore[attr-defined]
    shm.close()


def test_segments_a_crash_left_behind_are_swept_and_nothing_else() -> None:
    tag = os.urandom(3).hex()
    stale = [f"{prefix}sweeptest_{tag}" for prefix in PREFIXES]
    foreign = f"othersoftware_sweeptest_{tag}"
    for name in [*stale, foreign]:
        _leftover(name)
    live = FrameRing.create(2, 64, f"sweeptest_{tag}")  # mapped by this process: in use
    try:
        removed = sweep_stale_segments()
        listed = set(os.listdir("/dev/shm"))
        assert set(stale) <= set(removed) and not set(stale) & listed
        assert live.spec.shm_name in listed and live.spec.shm_name not in removed
        assert foreign in listed, "only cavewalk's own names are touched"
    finally:
        live.unlink()
        from multiprocessing import shared_memory

        shared_memory.SharedMemory(name=foreign).unlink()
