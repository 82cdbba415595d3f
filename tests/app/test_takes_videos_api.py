"""A take with camera videos through the real app: the pipeline on the real demo videos, the take
asked over HTTP with ``videos``, its MP4s indexed with their sha256 and served back unchanged."""

from __future__ import annotations

import json
import time
from dataclasses import replace
from pathlib import Path

import av
import httpx
import pytest

from pipeline.demo_data import DemoData
from pipeline.takes.files import check_files
from tests.app.conftest import Served, make_settings

pytestmark = pytest.mark.slow


def test_a_take_of_the_demo_videos_records_an_mp4_per_camera(tmp_path: Path, demo_data: DemoData) -> None:
    cams = {c: str(demo_data.videos[c]) for c in ("cam01", "cam02")}
    settings = make_settings(tmp_path)
    # the videos paced at 10 fps: a third of the decoding and encoding of 30, so that the capture
    # workers (niced below detection) keep up on a loaded 2-core machine
    settings = settings.model_copy(update={"runtime": replace(settings.runtime, video_pace_fps=10.0)})
    with Served(settings, autostart=None) as served:
        base = f"{served.base}/api/v1"
        r = httpx.post(f"{base}/pipeline/start", json={"source": "videos", "videos": cams}, timeout=60)
        assert r.status_code in (200, 202), r.text
        served.wait_status(lambda st: st["state"] == "running" and st["fps"] > 0, 120)
        r = httpx.post(f"{base}/takes", json={"duration_s": 3, "videos": True, "participant_code": "V1"})
        assert r.status_code == 201, r.text
        take = r.json()
        cur = httpx.get(f"{base}/takes/current").json()
        assert cur["recording"] and set(cur["videos"]) == set(cams), cur
        deadline = time.monotonic() + 120  # generous: the end waits for the encoders to close their files
        while (row := httpx.get(f"{base}/takes/{take['id']}").json())["status"] == "recording":
            assert time.monotonic() < deadline, row
            time.sleep(0.3)
        assert row["status"] == "complete", row
        folder = served.settings.paths.db.parent / "takes" / row["uid"]
        manifest = json.loads((folder / "take.json").read_text())
        assert check_files(folder) == []
        written = 0
        for cam in cams:
            stats = manifest["videos"][cam]
            assert stats["state"] == "closed" and stats["error"] is None, stats
            name = f"videos/{cam}.mp4"
            if not stats["written"]:  # its (niced) capture worker got no CPU in the take
                assert name not in row["files"], stats
                continue
            written += stats["written"]
            assert row["files"][name]["sha256"] == manifest["files"][name]["sha256"]
            got = httpx.get(f"{base}/takes/{take['id']}/files/{name}")
            assert got.status_code == 200 and got.content == (folder / name).read_bytes()
            with av.open(str(folder / name)) as c:
                times = [float(f.time) for f in c.decode(video=0)]
            assert len(times) == stats["written"] and all(0 <= t < 3.0 for t in times), times
        assert written >= 1, manifest["videos"]
