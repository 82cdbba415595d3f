"""The real pose model on frames of the real Pose2Sim demo videos."""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline.demo_data import DemoData
from pipeline.errors import InputError, ModelError
from pipeline.pixels import to_i420
from pipeline.pose.config import PoseConfig
from pipeline.pose.decode import RawPoses, iou_matrix
from pipeline.pose.detector import PoseDetector, merge
from pipeline.pose.model_files import crop_model_path
from pipeline.pose.roi import crop_region, roi_net_size, with_margin
from pipeline.pose.types import Job, ViewDetections
from pipeline.skeleton import J

FRAMES = (0, 60)


def read_frame(path: Path, index: int) -> np.ndarray:
    cap = cv2.VideoCapture(str(path))
    cap.set(cv2.CAP_PROP_POS_FRAMES, index)
    ok, frame = cap.read()
    cap.release()
    assert ok, f"{path} frame {index} must decode"
    return frame


@pytest.fixture(scope="module")
def demo_frames(demo_data: DemoData) -> dict[int, tuple[list[str], list[np.ndarray]]]:
    cams = list(demo_data.videos)
    return {k: (cams, [read_frame(demo_data.videos[c], k) for c in cams]) for k in FRAMES}


@pytest.fixture(scope="module")
def detector(pose_model_path: Path) -> PoseDetector:
    return PoseDetector.load(PoseConfig(threads=2, parallel=1), pose_model_path)


def subject(view: ViewDetections) -> int:
    """The main subject: the largest person in the view."""
    b = view.boxes_xyxy
    return int(np.argmax((b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])))


def crop_job(image: int, box: np.ndarray, view: ViewDetections, cfg: PoseConfig) -> Job:
    """The crop ROI mode makes around ``box`` of ``view`` (margin, network size of its own)."""
    region = with_margin(box, cfg.roi_margin)
    net = roi_net_size(cfg, region, view.image_size)
    return Job(image, crop_region(region, view.image_size, net), net)


def keypoint_gap(a: ViewDetections, i: int, b: ViewDetections, j: int,
                 min_score: float) -> tuple[float, float]:
    """Median distance between the keypoints of person ``i`` of ``a`` and ``j`` of ``b`` that both
    score above ``min_score``, and the height of person ``i``'s box (px)."""
    good = (a.keypoint_scores[i] > min_score) & (b.keypoint_scores[j] > min_score)
    err = np.linalg.norm(a.keypoints_xy[i][good] - b.keypoints_xy[j][good], axis=1)
    return float(np.median(err)), float(a.boxes_xyxy[i, 3] - a.boxes_xyxy[i, 1])


@pytest.mark.parametrize("frame", FRAMES)
def test_subject_found_in_all_four_views_with_plausible_keypoints(
    detector: PoseDetector, demo_frames: dict[int, tuple[list[str], list[np.ndarray]]], frame: int
) -> None:
    cams, images = demo_frames[frame]
    batch = detector.detect(images, cams, frame, frame / 60)
    assert [v.camera for v in batch.views] == cams
    assert batch.letterboxes[0].net_size == (384, 640), "portrait views go in as 384x640, not a square"
    for view, img in zip(batch.views, images, strict=True):
        assert view.image_size == (img.shape[1], img.shape[0])
        assert len(view) >= 1, f"{view.camera}: nobody found"
        i = subject(view)
        x1, y1, x2, y2 = view.boxes_xyxy[i]
        assert view.box_scores[i] > 0.6, f"{view.camera}: subject score {view.box_scores[i]}"
        assert y2 - y1 > 0.3 * img.shape[0], f"{view.camera}: the subject is a big person in the image"
        kp, sc = view.keypoints_xy[i], view.keypoint_scores[i]
        assert (sc > 0.5).sum() >= 12, f"{view.camera}: most keypoints visible, got {sc.round(2)}"
        for side in ("l", "r"):
            hip, knee, ankle = J[f"{side}_hip"], J[f"{side}_knee"], J[f"{side}_ankle"]
            assert kp[ankle, 1] > kp[knee, 1] > kp[hip, 1], f"{view.camera}: {side} ankle, knee, hip order"
        assert kp[J["nose"], 1] < kp[J["l_hip"], 1], f"{view.camera}: head above hips"
        vis = kp[sc > 0.5]
        tol = 0.05 * (y2 - y1)
        inside = ((vis[:, 0] >= x1 - tol) & (vis[:, 0] <= x2 + tol) & (vis[:, 1] >= y1 - tol)
                  & (vis[:, 1] <= y2 + tol))
        assert inside.all(), f"{view.camera}: visible keypoints lie inside the box"


def test_roi_crops_find_the_same_person(
    detector: PoseDetector, demo_frames: dict[int, tuple[list[str], list[np.ndarray]]]
) -> None:
    cams, images = demo_frames[FRAMES[1]]
    full = detector.detect(images, cams, 1, 0.0)
    cfg = PoseConfig()
    jobs = [crop_job(i, view.boxes_xyxy[subject(view)], view, cfg) for i, view in enumerate(full.views)]
    for job in jobs:
        assert job.net_size is not None and max(job.net_size) <= cfg.roi_long_side
    roi = detector.detect(images, cams, 1, 0.0, jobs=jobs)
    assert [b.net_size for b in roi.letterboxes] == [j.net_size for j in jobs], "each crop at its own size"
    for crop, whole in zip(roi.letterboxes, full.letterboxes, strict=True):
        assert crop.scale > 0.85 * whole.scale, "crops keep about the full-frame resolution"
    for f, r in zip(full.views, roi.views, strict=True):
        i = subject(f)
        assert len(r) >= 1, f"{r.camera}: subject lost in its crop"
        iou = iou_matrix(f.boxes_xyxy[i:i + 1], r.boxes_xyxy)[0]
        k = int(np.argmax(iou))
        assert iou[k] > 0.8, f"{r.camera}: crop box {r.boxes_xyxy[k]} vs full {f.boxes_xyxy[i]}"
        gap, height = keypoint_gap(f, i, r, k, 0.7)
        assert gap < 0.05 * height, f"{r.camera}: keypoints agree, median {gap:.1f} px"


def test_crop_cutting_a_person_drops_the_partial_detection(
    detector: PoseDetector, demo_frames: dict[int, tuple[list[str], list[np.ndarray]]]
) -> None:
    cams, images = demo_frames[FRAMES[0]]
    full = detector.detect(images[:1], cams[:1], 0, 0.0).views[0]
    x1, y1, x2, y2 = full.boxes_xyxy[subject(full)]
    # a crop holding only the upper half of the subject: the half person must not come out
    top = (float(x1) - 50, float(y1) - 50, float(x2) + 50, float((y1 + y2) / 2))
    cut = detector.detect(images[:1], cams[:1], 0, 0.0, jobs=[(0, top)], net_size=(256, 160)).views[0]
    iou = iou_matrix(cut.boxes_xyxy, full.boxes_xyxy[subject(full)][None])
    assert not (iou > 0.3).any(), f"a half person at the crop edge was kept: {cut.boxes_xyxy}"


def test_missing_model_says_how_to_make_it(tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="cavewalk models prepare"):
        PoseDetector.load(PoseConfig(parallel=1), tmp_path / "nope.onnx")


def test_a_file_that_is_not_a_model_is_a_model_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.onnx"
    bad.write_bytes(b"not an onnx file")
    with pytest.raises(ModelError, match="cannot load"):
        PoseDetector.load(PoseConfig(parallel=1), bad)


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"input_long_side": 100}, "multiple of 32"),
        ({"score_threshold": 1.5}, "score_threshold"),
        ({"nms_iou": -0.1}, "nms_iou"),
        ({"providers": ("tpu",)}, "providers"),
        ({"providers": ()}, "providers"),
        ({"threads": -1}, "threads"),
        ({"parallel": -1}, "parallel"),
    ],
)
def test_config_rejects_bad_values(changes: dict[str, object], match: str) -> None:
    base = PoseConfig()
    with pytest.raises(ValueError, match=match):
        replace(base, **changes)  # type: ignore[arg-type]


def test_cuda_requested_without_cuda_falls_back_to_cpu(pose_model_path: Path) -> None:
    det = PoseDetector.load(PoseConfig(providers=("cuda", "cpu"), threads=1, parallel=1), pose_model_path)
    assert det.providers[-1] == "CPUExecutionProvider"


def test_bad_images_are_input_errors(detector: PoseDetector) -> None:
    with pytest.raises(InputError, match="one image per camera"):
        detector.detect([np.zeros((64, 64, 3), np.uint8)], ["a", "b"], 0, 0.0)
    with pytest.raises(InputError, match="uint8 BGR"):
        detector.detect([np.zeros((64, 64), np.uint8)], ["a"], 0, 0.0)
    with pytest.raises(InputError, match="jobs must name images"):
        detector.detect([np.zeros((64, 64, 3), np.uint8)], ["a"], 0, 0.0, jobs=[(3, None)])


def test_an_empty_scene_gives_no_people(detector: PoseDetector) -> None:
    grey = np.full((640, 360, 3), 114, np.uint8)
    views = detector.detect([grey, grey], ["a", "b"], 7, 1.5).views
    assert [len(v) for v in views] == [0, 0]
    assert views[0].frame_index == 7 and views[0].timestamp_s == 1.5


def test_i420_frames_give_the_same_people_as_bgr(
    detector: PoseDetector, demo_frames: dict[int, tuple[list[str], list[np.ndarray]]]
) -> None:
    """The live pipeline hands the decoder's I420 frames to the detector: same people, same keypoints."""
    cams, images = demo_frames[FRAMES[1]]
    bgr = detector.detect(images, cams, 1, 0.0)
    yuv = detector.detect([to_i420(im) for im in images], cams, 1, 0.0)
    for a, b in zip(bgr.views, yuv.views, strict=True):
        assert b.image_size == a.image_size
        assert len(a) == len(b) > 0, f"{a.camera}: {len(a)} people from BGR, {len(b)} from I420"
        iou = iou_matrix(a.boxes_xyxy, b.boxes_xyxy)
        assert iou.max(axis=1).min() > 0.95, f"{a.camera}: boxes moved, IoU {iou.max(axis=1)}"
        i, j = subject(a), int(iou[subject(a)].argmax())
        gap, height = keypoint_gap(a, i, b, j, 0.5)
        assert gap < 0.01 * height, f"{a.camera}: keypoints {gap:.1f} px apart"


def test_parallel_runs_give_what_one_run_gives(
    pose_model_path: Path, demo_frames: dict[int, tuple[list[str], list[np.ndarray]]]
) -> None:
    """Crops of several sizes split over two threads: the same detections as one thread in turn."""
    cams, images = demo_frames[FRAMES[1]]
    one = PoseDetector.load(PoseConfig(threads=1, parallel=1), pose_model_path)
    two = PoseDetector.load(PoseConfig(parallel=2), pose_model_path)
    assert two.config.intra_op_threads == 1, "side-by-side runs use one onnxruntime thread each"
    full = one.detect(images, cams, 1, 0.0)
    cfg = PoseConfig()
    jobs = [Job(i, None, (192, 320)) for i in range(len(images))]  # coarse whole views, one size
    # and crops, of sizes that differ by view
    jobs += [crop_job(i, view.boxes_xyxy[subject(view)], view, cfg) for i, view in enumerate(full.views)]
    assert len({j.net_size for j in jobs}) >= 2
    a, b = one.detect(images, cams, 1, 0.0, jobs), two.detect(images, cams, 1, 0.0, jobs)
    for va, vb in zip(a.views, b.views, strict=True):
        assert len(va) == len(vb) > 0
        np.testing.assert_allclose(va.boxes_xyxy, vb.boxes_xyxy, atol=0.05)
        np.testing.assert_allclose(va.keypoints_xy, vb.keypoints_xy, atol=0.05)
    two.close()


def _poses(boxes: list[list[float]], scores: list[float]) -> RawPoses:
    n = len(boxes)
    kp = np.zeros((n, 17, 2), np.float32)
    return RawPoses(np.array(boxes, np.float32).reshape(n, 4), np.array(scores, np.float32), kp,
                    np.ones((n, 17), np.float32))


def test_a_whole_view_look_adds_newcomers_but_crops_keep_their_people() -> None:
    crop = _poses([[100, 100, 300, 700]], [0.6])
    whole = _poses([[105, 95, 305, 705], [600, 100, 800, 700]], [0.9, 0.8])  # the same person + a newcomer
    out = merge([crop], 0.6, 16, [whole])
    assert len(out) == 2
    np.testing.assert_array_equal(out.boxes_xyxy[0], crop.boxes_xyxy[0], err_msg="the crop's detection wins")
    np.testing.assert_array_equal(out.boxes_xyxy[1], whole.boxes_xyxy[1])
    assert len(merge([crop], 0.6, 1, [whole])) == 1, "max_people still holds"


def test_crops_on_the_crop_model_find_what_the_full_model_finds(
    pose_model_path: Path, demo_frames: dict[int, tuple[list[str], list[np.ndarray]]]
) -> None:
    """The head without its stride-8 level gives the people of person-sized crops to the pixel."""
    crop_model = crop_model_path(pose_model_path)
    full = PoseDetector.load(PoseConfig(threads=1, parallel=1), pose_model_path)
    cropped = PoseDetector.load(PoseConfig(threads=1, parallel=1), pose_model_path, crop_model)
    cfg = PoseConfig()
    for frame in FRAMES:
        cams, images = demo_frames[frame]
        found = full.detect(images, cams, 1, 0.0)
        # the subject and the bystander, each in a crop of its size
        jobs = [crop_job(i, box, view, cfg) for i, view in enumerate(found.views) for box in view.boxes_xyxy]
        a, b = full.detect(images, cams, 1, 0.0, jobs), cropped.detect(images, cams, 1, 0.0, jobs)
        for va, vb in zip(a.views, b.views, strict=True):
            assert len(va) == len(vb) > 0, f"{va.camera}: {len(va)} people vs {len(vb)} on the crop model"
            np.testing.assert_allclose(va.boxes_xyxy, vb.boxes_xyxy, atol=0.5)
            np.testing.assert_allclose(va.keypoints_xy, vb.keypoints_xy, atol=0.5)


def test_the_crop_model_is_used_when_it_is_there_and_wanted(pose_model_path: Path, tmp_path: Path) -> None:
    on = PoseConfig(model=pose_model_path)
    assert on.crop_model_file(pose_model_path) == crop_model_path(pose_model_path)
    off = PoseConfig(model=pose_model_path, crop_model=False)
    assert off.crop_model_file(pose_model_path) is None
    lone = tmp_path / "custom.onnx"
    shutil.copy2(pose_model_path, lone)
    assert on.crop_model_file(lone) is None, "no crop model beside it"
