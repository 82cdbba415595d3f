"""Letterbox geometry, output decoding and NMS (pure functions, no model)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.pose.decode import OUTPUT_CHANNELS, decode, iou_matrix, nms
from pipeline.pose.preprocess import (
    PAD_VALUE,
    Letterbox,
    expand_to_aspect,
    fit_region,
    letterbox_into,
    net_size_for,
)


@pytest.mark.parametrize(
    ("aspect", "long_side", "expected"),
    [
        (1080 / 1920, 640, (384, 640)),  # the demo's portrait views: no square padding
        (1088 / 1920, 640, (384, 640)),
        (1920 / 1080, 640, (640, 384)),
        (1.0, 320, (320, 320)),
        (1080 / 1920, 256, (160, 256)),
        (0.01, 64, (32, 64)),  # never below one stride
    ],
)
def test_net_size_follows_the_image_aspect(aspect: float, long_side: int, expected: tuple[int, int]) -> None:
    assert net_size_for(aspect, long_side) == expected


@pytest.mark.parametrize(
    ("aspect", "long_side", "match"),
    [(1.0, 100, "multiple of 32"), (1.0, 0, "multiple of 32"), (0.0, 640, "aspect"),
     (float("nan"), 64, "aspect")],
)
def test_net_size_rejects_bad_input(aspect: float, long_side: int, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        net_size_for(aspect, long_side)


@settings(max_examples=60, deadline=None)
@given(
    x1=st.floats(-500, 1500), y1=st.floats(-500, 1500),
    w=st.floats(10, 2000), h=st.floats(10, 2000),
    nw=st.sampled_from([160, 384, 640]), nh=st.sampled_from([256, 384, 640]),
    px=st.floats(0, 1), py=st.floats(0, 1),
)
def test_letterbox_round_trip_and_fit(x1: float, y1: float, w: float, h: float, nw: int, nh: int,
                                      px: float, py: float) -> None:
    box = fit_region((x1, y1, x1 + w, y1 + h), (nw, nh))
    p = np.array([[x1 + px * w, y1 + py * h]], np.float32)
    back = box.to_image(box.to_net(p))
    np.testing.assert_allclose(back, p, rtol=1e-5, atol=1e-2 * max(1.0, abs(p).max() * 1e-3))
    corners = box.to_net(np.array([[x1, y1], [x1 + w, y1 + h]], np.float32))
    # the region fits inside the network input, touching it on at least one axis, centred
    # tolerance: float32 rounding at image coordinates of a few thousand pixels is ~2e-3 px
    assert corners.min() >= -1e-2 and corners[1, 0] <= nw + 1e-2 and corners[1, 1] <= nh + 1e-2
    assert min(abs(corners[1, 0] - corners[0, 0] - nw), abs(corners[1, 1] - corners[0, 1] - nh)) < 1e-2
    np.testing.assert_allclose(corners.mean(axis=0), [nw / 2, nh / 2], atol=1e-2)


def test_letterbox_into_places_the_image_and_pads_grey() -> None:
    img = np.zeros((1920, 1080, 3), np.uint8)
    img[960:1160, 540:740] = (0, 0, 255)  # a red square in BGR
    box = fit_region((0, 0, 1080, 1920), (384, 640))
    out = np.empty((3, 640, 384), np.float32)
    letterbox_into(img, box, out)
    s = 640 / 1920
    cx, cy = box.to_net(np.array([[640.0, 1060.0]], np.float32))[0]
    assert out[0, int(cy), int(cx)] == pytest.approx(1.0), "red lands in channel 0 (RGB) at the mapped spot"
    assert out[2, int(cy), int(cx)] == pytest.approx(0.0)
    pad_x = (384 - 1080 * s) / 2
    assert pad_x > 1, "1080x1920 in 384x640 leaves a thin grey band on each side"
    assert out[1, 320, 0] == pytest.approx(PAD_VALUE / 255, abs=1e-3)
    assert out[1, 320, 192] == pytest.approx(0.0)


def test_crop_region_maps_back_to_the_source() -> None:
    rng = np.random.default_rng(0)
    img = rng.integers(0, 255, (600, 800, 3), dtype=np.uint8)
    box = fit_region((100, 50, 300, 370), (160, 256))
    out = np.empty((3, 256, 160), np.float32)
    letterbox_into(img, box, out)
    # a network pixel in the middle samples the image at box.to_image(pixel)
    src = box.to_image(np.array([[80.0, 128.0]], np.float32))[0]
    x, y = round(float(src[0])), round(float(src[1]))
    assert abs(out[0, 128, 80] * 255 - img[y, x, 2]) < 60, "crop sampled from the mapped place"


def test_letterbox_rejects_bad_shapes() -> None:
    box = fit_region((0, 0, 10, 10), (32, 32))
    with pytest.raises(ValueError, match="output must have shape"):
        letterbox_into(np.zeros((10, 10, 3), np.uint8), box, np.empty((3, 10, 10), np.float32))
    with pytest.raises(ValueError, match="BGR"):
        letterbox_into(np.zeros((10, 10), np.uint8), box, np.empty((3, 32, 32), np.float32))
    with pytest.raises(ValueError, match="positive width"):
        fit_region((5, 5, 5, 10), (32, 32))
    with pytest.raises(ValueError, match="scale"):
        Letterbox(0.0, (0, 0), (32, 32), (0, 0, 1, 1))


def test_expand_to_aspect_keeps_centre_and_contains_the_box() -> None:
    x1, y1, x2, y2 = expand_to_aspect((100, 200, 300, 700), 0.625, margin=0.1)
    assert (x1 + x2) / 2 == pytest.approx(200) and (y1 + y2) / 2 == pytest.approx(450)
    assert (x2 - x1) / (y2 - y1) == pytest.approx(0.625)
    assert x1 <= 100 and y1 <= 200 - 50 + 1e-9 and x2 >= 300 and y2 >= 700 + 50 - 1e-9


def test_iou_matrix_values() -> None:
    a = np.array([[0, 0, 10, 10], [0, 0, 0, 0]], np.float32)
    b = np.array([[0, 0, 10, 10], [5, 0, 15, 10], [20, 20, 30, 30]], np.float32)
    iou = iou_matrix(a, b)
    np.testing.assert_allclose(iou[0], [1.0, 50 / 150, 0.0])
    np.testing.assert_allclose(iou[1], [0.0, 0.0, 0.0], err_msg="degenerate boxes overlap nothing")


@pytest.mark.parametrize(
    ("boxes", "scores", "thr", "kept"),
    [
        ([[0, 0, 10, 10], [1, 1, 11, 11]], [0.9, 0.8], 0.5, [0]),  # IoU 0.68 -> suppressed
        ([[0, 0, 10, 10], [1, 1, 11, 11]], [0.7, 0.8], 0.5, [1]),  # the better one wins
        ([[0, 0, 10, 10], [1, 1, 11, 11]], [0.9, 0.8], 0.7, [0, 1]),  # below the threshold -> both
        ([[0, 0, 10, 10], [20, 0, 30, 10], [0, 1, 10, 11]], [0.5, 0.9, 0.6], 0.5, [1, 2]),
        ([], [], 0.5, []),
    ],
)
def test_nms(boxes: list[list[float]], scores: list[float], thr: float, kept: list[int]) -> None:
    b = np.array(boxes, np.float32).reshape(-1, 4)
    keep = nms(b, np.array(scores, np.float32), thr)
    assert keep.tolist() == kept


def test_nms_rejects_bad_threshold() -> None:
    with pytest.raises(ValueError, match=r"iou_threshold must be in \[0, 1\]"):
        nms(np.zeros((1, 4), np.float32), np.ones(1, np.float32), 1.5)


def _raw_output(people: list[tuple[float, float, float, float, float]], n_anchors: int = 50) -> np.ndarray:
    out = np.zeros((OUTPUT_CHANNELS, n_anchors), np.float32)
    for k, (cx, cy, w, h, score) in enumerate(people):
        out[:5, k] = (cx, cy, w, h, score)
        kp = np.stack([np.linspace(cx - w / 4, cx + w / 4, 17), np.linspace(cy - h / 3, cy + h / 3, 17),
                       np.full(17, 0.9)], axis=1)
        out[5:, k] = kp.reshape(-1)
    return out


def test_decode_boxes_keypoints_threshold_and_nms() -> None:
    out = _raw_output([(100, 200, 50, 150, 0.9), (102, 201, 50, 150, 0.8), (300, 200, 40, 120, 0.5),
                       (500, 100, 40, 40, 0.2)])
    poses = decode(out, score_threshold=0.35, iou_threshold=0.6)
    assert len(poses) == 2, "the near-duplicate is suppressed, the low score dropped"
    np.testing.assert_allclose(poses.boxes_xyxy[0], [75, 125, 125, 275])
    np.testing.assert_allclose(poses.scores, [0.9, 0.5])
    np.testing.assert_allclose(poses.keypoints_xy[0, 0], [87.5, 150.0])
    np.testing.assert_allclose(poses.keypoint_scores[1], 0.9, rtol=1e-6)
    assert len(decode(out, 0.95, 0.6)) == 0


def test_decode_rejects_a_wrong_output_shape() -> None:
    with pytest.raises(ValueError, match=r"\(56, N\)"):
        decode(np.zeros((84, 10), np.float32), 0.3, 0.5)
