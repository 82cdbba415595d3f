"""The run plan (issue 16 item 5): every bad start is one clear error before anything runs."""

from __future__ import annotations

from pathlib import Path

import pytest

from pipeline.camera import Camera
from pipeline.errors import CavewalkError, InputError, SourceError
from pipeline.runtime.config import RuntimeConfig
from pipeline.runtime.plan import PlanInputs, plan_run


def inputs(tmp_path: Path, **kw: object) -> PlanInputs:
    base = {"config": RuntimeConfig(), "camera_sources": {"cam01": "sim"}, "cameras_calibrated": None,
            "has_pose": True, "has_simulator": True}
    return PlanInputs(**(base | kw))  # type: ignore[arg-type]


@pytest.mark.parametrize(("source", "videos", "kw", "error", "match"), [
    ("webcam", None, {}, InputError, "source must be one of"),
    ("simulator", None, {"has_simulator": False}, SourceError, "simulator is not available"),
    ("cameras", None, {}, SourceError, "no camera has a real source"),
    ("cameras", None, {"camera_sources": {"cam01": "/nowhere/clip.mp4"}}, SourceError, "not found"),
    ("videos", None, {}, InputError, "at least one video"),
    ("videos", {"cam01": Path("/nowhere/a.mp4")}, {}, InputError, "video not found"),
    ("videos", {"cam09": "FILE"}, {"cameras_calibrated": ()}, InputError, "not in the calibration"),
    ("videos", {"cam01": "FILE"}, {"has_pose": False}, SourceError, "no pose detector"),
])
def test_a_bad_start_is_one_error(tmp_path: Path, source: str, videos: dict[str, Path] | None,
                                  kw: dict[str, object], error: type[CavewalkError], match: str) -> None:
    folder = tmp_path / "frames"
    folder.mkdir()
    if videos is not None:
        videos = {k: (folder / "x.png" if v == "FILE" else v) for k, v in videos.items()}
        (folder / "x.png").write_bytes(b"not checked here")
    with pytest.raises(error, match=match):
        plan_run(source, videos, inputs(tmp_path, **kw))


def test_a_good_plan_names_each_capture_worker(tmp_path: Path) -> None:
    folder = tmp_path / "cam02"
    folder.mkdir()
    cams = {"cam01": "sim", "cam02": str(folder)}
    assert plan_run("simulator", None, inputs(tmp_path)) == {}, "the simulator needs no capture worker"
    assert plan_run("cameras", None, inputs(tmp_path, camera_sources=cams)) == {"cam02": str(folder)}
    calibrated = (Camera.from_dict({"name": "cam02", "image_size": [640, 480],
                                    "K": [[500, 0, 320], [0, 500, 240], [0, 0, 1]],
                                    "dist": [0, 0, 0, 0, 0], "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
                                    "t": [0, 0, 0]}),)
    assert plan_run("cameras", None, inputs(tmp_path, camera_sources=cams, cameras_calibrated=calibrated))
