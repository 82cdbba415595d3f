"""Image sources on real files: the Pose2Sim demo videos and an image folder."""

from __future__ import annotations

import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline.demo_data import DemoData
from pipeline.errors import SourceError
from pipeline.pixels import pixel_format, to_bgr
from pipeline.sources import open_source, source_kind
from pipeline.sources.opencv import ImageFolderSource, Pacer, VideoFileSource
from pipeline.sources.types import CapturedFrame, FrameSource, iter_frames


def test_video_once_delivers_every_frame_with_rising_timestamps(demo_data: DemoData) -> None:
    path = demo_data.videos["cam01"]
    src = VideoFileSource("cam01", path)
    assert isinstance(src, FrameSource)
    assert src.nominal_fps == pytest.approx(60.0, abs=0.5)
    frames = [(f.index, f.timestamp_s, f.image_size) for f in iter_frames(src)]
    assert len(frames) == src.frame_count == 100, "the demo video has 100 frames"
    assert [i for i, _, _ in frames] == list(range(100))
    stamps = np.array([t for _, t, _ in frames])
    assert np.all(np.diff(stamps) > 0), "capture timestamps must increase"
    assert frames[0][2][0] < frames[0][2][1], "the demo views are portrait"
    assert src.read() is None, "a closed source delivers nothing"


def test_video_loop_continues_the_index(demo_data: DemoData) -> None:
    src = VideoFileSource("cam02", demo_data.videos["cam02"], loop=True)
    try:
        indices = [src.read().index for _ in range(130)]  # type: ignore[union-attr]
    finally:
        src.close()
    assert indices == list(range(130)), "looping keeps counting frames"
    assert src.loops == 1


def test_native_video_frames_are_the_decoders_i420(demo_data: DemoData) -> None:
    """PyAV hands over I420 (half the bytes, no conversion); as BGR it is OpenCV's frame within 2 levels."""
    native = VideoFileSource("cam01", demo_data.videos["cam01"], native=True, loop=True)
    plain = VideoFileSource("cam01", demo_data.videos["cam01"])
    try:
        assert native.nominal_fps == pytest.approx(plain.nominal_fps or 0.0, abs=0.01)
        assert native.frame_count == plain.frame_count == 100
        a, b = native.read(), plain.read()
        assert a is not None and b is not None
        assert pixel_format(a.image) == "i420" and pixel_format(b.image) == "bgr"
        assert a.image_size == b.image_size and a.image.nbytes * 2 == b.image.nbytes
        diff = np.abs(to_bgr(a.image).astype(int) - b.image.astype(int))
        assert diff.mean() < 2.0 and np.percentile(diff, 99) <= 3, f"colours differ by {diff.mean():.2f}"
        indices = [a.index] + [f.index for f in (native.read() for _ in range(120)) if f is not None]
        assert indices == list(range(121)) and native.loops == 1, "native frames loop like the others"
    finally:
        native.close()
        plain.close()
    assert native.read() is None


def test_a_native_frame_is_decoded_straight_into_a_ring_slot(demo_data: DemoData) -> None:
    """The capture worker's path: the decoder writes into the claimed slot, the reader gets it back."""
    from pipeline.runtime.shm import FrameRing

    a = VideoFileSource("cam02", demo_data.videos["cam02"], native=True)
    b = VideoFileSource("cam02", demo_data.videos["cam02"], native=True)
    ring = FrameRing.create(2, 1088 * 1920 * 3, "t")
    try:
        assert a.grab() and b.grab()
        claimed: list[np.ndarray] = []

        def into_ring(shape: tuple[int, ...]) -> np.ndarray:
            claimed.append(ring.claim(shape))
            return claimed[-1]

        frame = a.retrieve(into_ring)
        assert frame is not None and frame.image is claimed[0], "no copy of its own"
        assert ring.latest_seq == -1, "nothing is published before publish()"
        ring.publish(frame.image.shape, frame.timestamp_s, frame.index)
        slot = ring.read_latest()
        plain = b.retrieve()
        assert slot is not None and plain is not None
        np.testing.assert_array_equal(slot.image, plain.image)
    finally:
        a.close()
        b.close()
        ring.unlink()


def test_native_open_of_a_broken_video_is_a_source_error(tmp_path: Path) -> None:
    bad = tmp_path / "broken.mp4"
    bad.write_bytes(b"\x00" * 1000)
    with pytest.raises(SourceError, match="cannot open video"):
        open_source(str(bad), "cam09", native=True)


def test_paced_source_keeps_its_clock_and_skips_what_it_missed(demo_data: DemoData) -> None:
    pacer = Pacer(30.0)
    src = VideoFileSource("cam01", demo_data.videos["cam01"], pace_fps=30.0, start_s=pacer.start_s)
    try:
        first = src.read()
        time.sleep(0.2)  # a slow reader: at 30 fps at least 6 slots have come meanwhile
        late = src.read()
    finally:
        src.close()
    assert first is not None and late is not None
    assert first.timestamp_s >= pacer.start_s - 1e-3, "a paced frame is never delivered before it is due"
    assert late.index >= 6, f"the source follows its clock, got frame {late.index} after 0.2 s"
    assert src.skipped == late.index - 1, "every slot not delivered is counted as skipped"


def test_image_folder_in_name_order(tmp_path: Path) -> None:
    for i in (2, 0, 1):
        cv2.imwrite(str(tmp_path / f"img{i:03d}.png"), np.full((20, 30, 3), i * 50, np.uint8))
    (tmp_path / "notes.txt").write_text("not an image")
    frames = list(iter_frames(ImageFolderSource("c", tmp_path)))
    assert [int(f.image[0, 0, 0]) for f in frames] == [0, 50, 100]
    assert frames[0].image_size == (30, 20)


def test_image_folder_loops(tmp_path: Path) -> None:
    cv2.imwrite(str(tmp_path / "a.png"), np.zeros((4, 4, 3), np.uint8))
    src = ImageFolderSource("c", tmp_path, loop=True)
    assert [src.read().index for _ in range(3)] == [0, 1, 2]  # type: ignore[union-attr]


def test_image_that_vanishes_raises_source_error(tmp_path: Path) -> None:
    cv2.imwrite(str(tmp_path / "a.png"), np.zeros((4, 4, 3), np.uint8))
    src = ImageFolderSource("c", tmp_path)
    (tmp_path / "a.png").unlink()
    with pytest.raises(SourceError, match="cannot read image"):
        src.read()


@pytest.mark.parametrize(
    ("uri", "kind"),
    [("0", "device"), ("12", "device"), ("rtsp://10.0.0.5/stream", "stream"),
     ("http://cam.local/video.mjpg", "stream"), ("sim", "sim"), ("/no/such/video.mp4", "video")],
)
def test_source_kind(uri: str, kind: str) -> None:
    assert source_kind(uri) == kind


def test_source_kind_folder(tmp_path: Path) -> None:
    assert source_kind(str(tmp_path)) == "folder"


@pytest.mark.parametrize(
    ("uri", "match"),
    [
        ("/no/such/video.mp4", "not a device index, URL, video file or folder"),
        ("sim", "is the simulator"),
        ("", "empty source"),
        ("97", "cannot open 97"),
    ],
)
def test_open_source_errors(uri: str, match: str) -> None:
    with pytest.raises(SourceError, match=match):
        open_source(uri, "camX")


def test_open_source_rejects_a_file_that_is_not_a_video(tmp_path: Path) -> None:
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"this is not a video")
    with pytest.raises(SourceError, match="cannot open video"):
        open_source(str(bad), "camX")


def test_open_source_opens_video_and_folder(demo_data: DemoData, tmp_path: Path) -> None:
    cv2.imwrite(str(tmp_path / "a.jpg"), np.zeros((8, 8, 3), np.uint8))
    for uri in (str(demo_data.videos["cam03"]), str(tmp_path)):
        src = open_source(uri, "cam03")
        frame = src.read()
        src.close()
        assert isinstance(frame, CapturedFrame) and frame.camera == "cam03"


@pytest.mark.parametrize(
    ("image", "index", "match"),
    [
        (np.zeros((4, 4), np.uint8), 0, "expected an \\(H, W, 3\\) uint8 BGR image"),
        (np.zeros((4, 4, 3), np.float32), 0, "expected an \\(H, W, 3\\) uint8 BGR image"),
        (np.zeros((4, 4, 3), np.uint8), -1, "index must be >= 0"),
    ],
)
def test_captured_frame_validation(image: np.ndarray, index: int, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        CapturedFrame("c", index, 0.0, image)
