"""The pose model preparation and the demo data, through the same code the CLI runs."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import cv2
import onnx
import pytest

from pipeline.demo_data import DemoData, fetch_demo
from pipeline.pose.prepare import (
    PreparedModel,
    crop_model_path,
    int8_path,
    prepare_int8_model,
    prepare_pose_model,
    sha256_file,
    verify_onnx,
)


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
    prepared = prepare_pose_model(tmp_path, progress=messages.append, int8=False)
    assert prepared.created is True
    assert any("does not match" in m for m in messages)
    verify_onnx(prepared.path)


def test_int8_model_is_produced_verified_and_checksummed(pose_model_path: Path) -> None:
    path = int8_path(pose_model_path)
    assert path.name == "yolo11n-pose.int8.onnx"
    meta = json.loads(path.with_suffix(".json").read_text())
    assert meta["sha256"] == sha256_file(path)
    assert meta["source_sha256"] == sha256_file(pose_model_path), "made from the current fp32 file"
    assert verify_onnx(path)[:2] == (2, 56)
    nodes = onnx.load(str(path)).graph.node
    quantized = {n.input[0] for n in nodes if n.op_type == "DequantizeLinear"}
    convs = {n.name: n for n in nodes if n.op_type == "Conv"}
    backbone = convs["/model.0/conv/Conv"]
    keypoint_out = next(n for name, n in convs.items() if "/cv4.0/cv4.0.2/" in name)
    assert any(i.endswith("_DequantizeLinear_Output") for i in backbone.input), "backbone runs in int8"
    assert not any(i.endswith("_DequantizeLinear_Output") for i in keypoint_out.input), \
        "the keypoint head stays float32"
    assert quantized, "the file has quantized tensors"


def test_crop_model_is_the_model_without_its_stride8_level(pose_model_path: Path) -> None:
    crop = crop_model_path(pose_model_path)
    assert crop.name == "yolo11n-pose.crop.onnx"
    assert crop_model_path(int8_path(pose_model_path)).name == "yolo11n-pose.crop.int8.onnx"
    for path in (crop, int8_path(crop)):
        meta = json.loads(path.with_suffix(".json").read_text())
        assert meta["sha256"] == sha256_file(path), f"{path.name} is checksummed"
    assert json.loads(crop.with_suffix(".json").read_text())["head_strides"] == [16, 32]
    full_anchors = verify_onnx(pose_model_path)[2]
    crop_shape = verify_onnx(crop)
    assert crop_shape[:2] == (2, 56) and verify_onnx(int8_path(crop))[:2] == (2, 56)
    assert full_anchors - crop_shape[2] == (384 // 8) * (640 // 8), "exactly the stride-8 anchors are gone"


def test_int8_prepare_is_idempotent(pose_model_path: Path, demo_data: DemoData) -> None:
    fp32 = PreparedModel(pose_model_path, sha256_file(pose_model_path), created=False)
    messages: list[str] = []
    again = prepare_int8_model(fp32, demo_data.root.parents[2], progress=messages.append)
    assert again is not None and again.created is False, messages
    assert again.path == int8_path(pose_model_path)


@pytest.mark.slow
def test_int8_made_another_way_is_made_again(
    pose_model_path: Path, demo_data: DemoData, tmp_path: Path
) -> None:
    for src in (pose_model_path, int8_path(pose_model_path)):
        for f in (src, src.with_suffix(".json")):
            shutil.copy2(f, tmp_path / f.name)
    meta_file = tmp_path / "yolo11n-pose.int8.json"
    meta = json.loads(meta_file.read_text())
    meta["recipe"] = "an older recipe"
    meta_file.write_text(json.dumps(meta))
    fp32 = PreparedModel(tmp_path / pose_model_path.name, sha256_file(pose_model_path), created=False)
    messages: list[str] = []
    made = prepare_int8_model(fp32, demo_data.root.parents[2], progress=messages.append)
    assert made is not None and made.created is True, messages
    assert any("quantized another way" in m for m in messages), messages
    assert json.loads(meta_file.read_text())["recipe"] != "an older recipe"
    assert json.loads(meta_file.read_text())["sha256"] == sha256_file(made.path)
    assert verify_onnx(made.path)[:2] == (2, 56)


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
