"""Sources: cameras, synchronised video files, image folders and the simulator, behind one interface.

``open_source(uri, name)`` opens what a camera's ``source`` setting names: an integer
device index (``"0"``), a stream URL (``rtsp://``, ``http://``...), a video file or an
image folder. ``sim`` is the simulator, which is not an image source: it hands on
detections directly (see :mod:`pipeline.sources.sim`).

The frame types are in :mod:`pipeline.sources.types`, the multi-view grouper in
:mod:`pipeline.sources.grouper`. This package imports neither them nor cv2, so that the settings
can read :class:`~pipeline.sources.grouper.GrouperConfig` without loading OpenCV.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from pipeline.errors import SourceError

if TYPE_CHECKING:
    from pipeline.sources.types import FrameSource

STREAM_SCHEMES = ("rtsp://", "rtsps://", "http://", "https://", "udp://", "tcp://", "rtmp://")

__all__ = ["open_source", "source_kind"]


def source_kind(uri: str) -> str:
    """``device``, ``stream``, ``video``, ``folder`` or ``sim`` for a source URI (no I/O for streams)."""
    text = uri.strip()
    if text == "sim":
        return "sim"
    if text.isdigit():
        return "device"
    if text.lower().startswith(STREAM_SCHEMES):
        return "stream"
    return "folder" if Path(text).expanduser().is_dir() else "video"


def open_source(uri: str, name: str, *, pace_fps: float | None = None, loop: bool = False,
                start_s: float | None = None, native: bool = False) -> FrameSource:
    """Open the image source a camera setting names; :class:`SourceError` when it does not open.

    pace_fps / loop / start_s apply to files and folders (live cameras pace themselves).
    native: a video file delivers its decoder's I420 frames instead of BGR (see
    :mod:`pipeline.pixels`); other sources deliver BGR either way.
    """
    # cv2 is heavy, and the settings import GrouperConfig from this package: load it to open a source
    from pipeline.sources.opencv import CameraSource, ImageFolderSource, VideoFileSource

    kind = source_kind(uri)
    if not uri.strip():
        raise SourceError(f"camera {name}: empty source")
    if kind == "sim":
        raise SourceError(f"camera {name}: 'sim' is the simulator; start the pipeline with the "
                          "simulator source instead of opening it as a camera")
    if kind == "device":
        return CameraSource(name, int(uri))
    if kind == "stream":
        return CameraSource(name, uri.strip())
    path = Path(uri.strip()).expanduser()
    if kind == "folder":
        return ImageFolderSource(name, path, loop=loop, pace_fps=pace_fps, start_s=start_s)
    if not path.exists():
        raise SourceError(f"camera {name}: source {uri!r} is not a device index, URL, video file or folder")
    return VideoFileSource(name, path, loop=loop, pace_fps=pace_fps, start_s=start_s, native=native)
