"""A finished take shown in the 3D view at a chosen time, while the operator edits its labels.

:class:`TakeReplay` reads the take's ``frames.jsonl`` once (kept while its sha256 stays the same)
and hands the frame at the asked time to :meth:`app.viewer.Viewer.show_replay`, in the shape of a
live snapshot: every person's skeleton with its user id, the navigator and its arrow. The live
people come back on :meth:`stop`, or by themselves once the view has had no frame for a while.
"""

from __future__ import annotations

import bisect
import threading
from pathlib import Path
from typing import Any

from app.db.errors import StateConflict
from app.viewer import Viewer
from pipeline.errors import InputError
from pipeline.takes.files import FRAMES, read_frames


class TakeReplay:
    def __init__(self, viewer: Viewer | None) -> None:
        self._viewer = viewer
        self._lock = threading.Lock()
        self._key: tuple[int, str | None] | None = None
        self._times: list[float] = []
        self._frames: list[dict[str, Any]] = []

    def show(self, take_id: int, folder: Path, files: dict[str, Any], t_s: float) -> dict[str, Any]:
        """Show the take's frame at ``t_s`` seconds (the last one captured at or before it)."""
        if self._viewer is None:
            raise StateConflict("the 3D view is off (server.viser = false): nothing to replay in")
        digest = (files.get(FRAMES) or {}).get("sha256")
        with self._lock:
            if self._key != (take_id, digest):
                frames, _ = read_frames(Path(folder) / FRAMES)
                if not frames:
                    raise InputError(f"take {take_id} has no frames to replay")
                self._frames = frames
                self._times = [float(f["t"]) for f in frames]
                self._key = (take_id, digest)
            i = max(0, bisect.bisect_right(self._times, t_s) - 1)
            frame = self._frames[i]
        people = frame.get("people3d") or []
        self._viewer.show_replay({"extra": {"people3d": people}, "navigator": frame.get("navigator"),
                                  "action": frame.get("action") or {}, "people": []})
        return {"take_id": take_id, "t_s": t_s, "frame_t_s": self._times[i], "frame": frame.get("frame"),
                "index": i, "users": sorted(int(p["user_id"]) for p in people),
                "navigator": frame.get("navigator")}

    def stop(self) -> None:
        if self._viewer is not None:
            self._viewer.show_replay(None)
