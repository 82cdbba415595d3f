"""What a source hands on: one captured image of one camera, with its capture time."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from pipeline.pixels import image_size, pixel_format

U8 = NDArray[np.uint8]


@dataclass(frozen=True, slots=True)
class CapturedFrame:
    """One image of one camera.

    camera: camera name.
    index: running index of this camera's frames (0, 1, 2, ...; gaps where frames were skipped).
    timestamp_s: capture time, seconds on ``time.monotonic()`` (one clock for every process).
    image: (H, W, 3) uint8 BGR, or (H * 3 / 2, W) uint8 I420 from a video decoder that was
        asked for its native frames (see :mod:`pipeline.pixels`).
    """

    camera: str
    index: int
    timestamp_s: float
    image: U8

    def __post_init__(self) -> None:
        try:
            pixel_format(self.image)
        except ValueError as exc:
            raise ValueError(f"{self.camera}: {exc}") from None
        if self.index < 0:
            raise ValueError(f"{self.camera}: index must be >= 0, got {self.index}")

    @property
    def image_size(self) -> tuple[int, int]:
        """(width, height) in pixels."""
        return image_size(self.image)


@runtime_checkable
class FrameSource(Protocol):
    """A camera, a video file or an image folder, read frame by frame.

    ``read()`` blocks until the next frame is due (paced sources) and returns None once
    the source has ended; it raises :class:`pipeline.errors.SourceError` when the device
    fails. ``grab()`` takes a frame without the cost of converting it, so a reader that
    does not need every frame skips the conversion. ``close()`` releases the device and
    may be called twice.
    """

    name: str

    def read(self) -> CapturedFrame | None: ...

    def grab(self) -> bool:
        """Take the next frame without converting it (``read`` = ``grab`` + ``retrieve``)."""
        ...

    def retrieve(self, alloc: Callable[[tuple[int, ...]], U8] | None = None) -> CapturedFrame | None:
        """The frame last grabbed, converted to a BGR image (I420 for a native video source), in
        the array ``alloc(shape)`` returns when given (so a capture worker decodes straight
        into shared memory)."""
        ...

    def close(self) -> None: ...

    @property
    def nominal_fps(self) -> float | None: ...


def iter_frames(source: FrameSource) -> Iterator[CapturedFrame]:
    """All frames of a source until it ends (closes it at the end)."""
    try:
        while (frame := source.read()) is not None:
            yield frame
    finally:
        source.close()
