"""Pre-processing for YOLO-pose: letterbox an image (or a region of it) into the network input.

A letterbox is one similarity transform ``net = scale * image + offset``: the region is
scaled uniformly to fit the network rectangle and centred, the rest is filled with grey
(114, as Ultralytics does). One ``cv2.warpAffine`` does crop + resize + pad in a single
pass whose cost depends on the output size only, so a crop never copies the source.
An I420 image (:mod:`pipeline.pixels`) is warped plane by plane and turned into RGB at
the network size, so the full frame is never converted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from pipeline.pixels import i420_planes, pixel_format
from pipeline.pose.config import STRIDE

F32 = NDArray[np.float32]
U8 = NDArray[np.uint8]
PAD_VALUE = 114
CHROMA_PAD = 128  # U and V of grey: the I420 letterbox pads with the same grey (Y = 114)


@dataclass(frozen=True, slots=True)
class Letterbox:
    """The map from image pixels to network-input pixels: ``net = scale * image + offset``.

    scale: uniform scale factor (network px per image px).
    offset_xy: (2,) translation in network px.
    net_size: (width, height) of the network input.
    region_xyxy: the image region that was fitted into the input [x1, y1, x2, y2], px.
    """

    scale: float
    offset_xy: tuple[float, float]
    net_size: tuple[int, int]
    region_xyxy: tuple[float, float, float, float]

    def __post_init__(self) -> None:
        if not (math.isfinite(self.scale) and self.scale > 0):
            raise ValueError(f"scale must be a positive finite number, got {self.scale}")
        if self.net_size[0] <= 0 or self.net_size[1] <= 0:
            raise ValueError(f"net_size must be positive (w, h), got {self.net_size}")

    @property
    def matrix(self) -> NDArray[np.float64]:
        """(2, 3) affine matrix image -> network input, for ``cv2.warpAffine``.

        ``scale``/``offset_xy`` map continuous coordinates (pixel i spans [i, i + 1], as the
        model's outputs do); warpAffine maps pixel indices, hence the half-pixel term.
        """
        s = self.scale
        h = 0.5 * (s - 1.0)
        return np.array([[s, 0.0, self.offset_xy[0] + h], [0.0, s, self.offset_xy[1] + h]], dtype=np.float64)

    def to_image(self, xy: F32) -> F32:
        """Network-input points (..., 2) back to image pixels."""
        out = np.asarray(xy, dtype=np.float32).copy()
        out[..., 0] = (out[..., 0] - self.offset_xy[0]) / self.scale
        out[..., 1] = (out[..., 1] - self.offset_xy[1]) / self.scale
        return out

    def to_net(self, xy: F32) -> F32:
        """Image points (..., 2) to network-input pixels."""
        out = np.asarray(xy, dtype=np.float32).copy()
        out[..., 0] = out[..., 0] * self.scale + self.offset_xy[0]
        out[..., 1] = out[..., 1] * self.scale + self.offset_xy[1]
        return out


def round_up(value: float, multiple: int = STRIDE) -> int:
    return int(math.ceil(value / multiple - 1e-9) * multiple)


def net_size_for(aspect_wh: float, long_side: int) -> tuple[int, int]:
    """Network input (width, height) for images of aspect ``w / h``: the long side is
    ``long_side``, the short side the smallest multiple of 32 that holds the image.

    >>> net_size_for(1080 / 1920, 640)
    (384, 640)
    """
    if long_side <= 0 or long_side % STRIDE:
        raise ValueError(f"long_side must be a positive multiple of {STRIDE}, got {long_side}")
    if not (math.isfinite(aspect_wh) and aspect_wh > 0):
        raise ValueError(f"aspect must be positive, got {aspect_wh}")
    if aspect_wh >= 1.0:
        return long_side, max(STRIDE, round_up(long_side / aspect_wh))
    return max(STRIDE, round_up(long_side * aspect_wh)), long_side


def fit_region(region_xyxy: tuple[float, float, float, float], net_size: tuple[int, int]) -> Letterbox:
    """The letterbox that fits ``region_xyxy`` of an image centred into ``net_size``."""
    x1, y1, x2, y2 = (float(v) for v in region_xyxy)
    w, h = x2 - x1, y2 - y1
    if not (w > 0 and h > 0):
        raise ValueError(f"region must have positive width and height, got {region_xyxy}")
    nw, nh = net_size
    scale = min(nw / w, nh / h)
    ox = (nw - scale * w) / 2.0 - scale * x1
    oy = (nh - scale * h) / 2.0 - scale * y1
    return Letterbox(scale, (ox, oy), (int(nw), int(nh)), (x1, y1, x2, y2))


def letterbox_into(image: U8, box: Letterbox, out_chw: F32) -> None:
    """Warp ``image`` through ``box`` into ``out_chw`` (3, h, w) RGB float32 in [0, 1].

    image: (H, W, 3) BGR uint8, or (H * 3 / 2, W) I420 uint8 (see :mod:`pipeline.pixels`).
    """
    nw, nh = box.net_size
    if out_chw.shape != (3, nh, nw):
        raise ValueError(f"output must have shape (3, {nh}, {nw}), got {out_chw.shape}")
    if pixel_format(image) == "i420":
        rgb = _warp_i420(image, box)
    else:
        warped = cv2.warpAffine(
            image, box.matrix, (nw, nh), flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT, borderValue=(PAD_VALUE, PAD_VALUE, PAD_VALUE),
        )
        rgb = warped[:, :, ::-1]
    # HWC uint8 -> RGB CHW float32 / 255 in one strided pass
    np.multiply(rgb.transpose(2, 0, 1), np.float32(1.0 / 255.0), out=out_chw)


def _warp_i420(image: U8, box: Letterbox) -> U8:
    """The letterboxed (h, w, 3) RGB of an I420 image: Y warped at the network size, U and V at
    half of it (a chroma pixel spans two luma pixels: same scale, half the offset), then one
    YUV -> RGB conversion of the small result. The network size is a multiple of 32, so even."""
    nw, nh = box.net_size
    y, u, v = i420_planes(image)
    yuv = np.empty((nh * 3 // 2, nw), np.uint8)
    flags, border = cv2.INTER_LINEAR, cv2.BORDER_CONSTANT
    cv2.warpAffine(y, box.matrix, (nw, nh), dst=yuv[:nh], flags=flags, borderMode=border,
                   borderValue=PAD_VALUE)
    half = Letterbox(box.scale, (box.offset_xy[0] / 2.0, box.offset_xy[1] / 2.0), (nw // 2, nh // 2),
                     box.region_xyxy).matrix
    quarter = nh // 4
    for k, plane in enumerate((u, v)):
        warped = cv2.warpAffine(plane, half, (nw // 2, nh // 2), flags=flags, borderMode=border,
                                borderValue=CHROMA_PAD)
        yuv[nh + k * quarter: nh + (k + 1) * quarter] = warped.reshape(quarter, nw)
    return np.asarray(cv2.cvtColor(yuv, cv2.COLOR_YUV2RGB_I420), dtype=np.uint8)


def expand_to_aspect(region_xyxy: tuple[float, float, float, float], aspect_wh: float,
                     margin: float = 0.0, min_height: float = 0.0) -> tuple[float, float, float, float]:
    """Grow a region by ``margin`` (fraction of its height on each side), then to aspect ``w / h``
    around its centre, and to at least ``min_height`` pixels tall."""
    x1, y1, x2, y2 = region_xyxy
    cx, cy = (x1 + x2) / 2.0, (y1 + y2) / 2.0
    w, h = max(x2 - x1, 1.0), max(y2 - y1, 1.0)
    pad = margin * max(w, h)
    w, h = w + 2 * pad, h + 2 * pad
    h = max(h, w / aspect_wh, min_height)
    w = h * aspect_wh
    return cx - w / 2.0, cy - h / 2.0, cx + w / 2.0, cy + h / 2.0
