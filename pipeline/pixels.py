"""Pixel formats of camera images: BGR and planar YUV 4:2:0 (I420).

A video decoder delivers I420; turning a whole 1080x1920 frame into BGR costs about as
much again as decoding it (PyAV on the demo videos: 2.1-2.7 ms to decode into I420,
4.4-5.0 ms into BGR, per frame on this machine's cores). The live pipeline therefore
keeps video frames in I420 from the decoder to the pose model's letterbox, which
converts only the network's few pixels, and moves half the bytes through shared memory.

An image is BGR when it is (H, W, 3) uint8 and I420 when it is (H * 3 / 2, W) uint8:
the Y plane (H, W), then the U and the V plane (H / 2, W / 2) each, H and W even.
"""

from __future__ import annotations

from typing import Literal

import cv2
import numpy as np
from numpy.typing import NDArray

U8 = NDArray[np.uint8]
PixelFormat = Literal["bgr", "i420"]


def pixel_format(image: U8) -> PixelFormat:
    """``"bgr"`` or ``"i420"`` from the shape; ValueError for anything else."""
    if image.dtype == np.uint8:
        if image.ndim == 3 and image.shape[2] == 3:
            return "bgr"
        if image.ndim == 2 and image.shape[0] % 3 == 0 and image.shape[1] % 2 == 0:
            return "i420"
    raise ValueError(f"expected an (H, W, 3) uint8 BGR image or an (H * 3 / 2, W) uint8 I420 image with "
                     f"H and W even, got {image.shape} {image.dtype}")


def image_size(image: U8) -> tuple[int, int]:
    """(width, height) of the picture, in pixels, for either format."""
    if pixel_format(image) == "i420":
        return int(image.shape[1]), int(image.shape[0]) * 2 // 3
    return int(image.shape[1]), int(image.shape[0])


def i420_planes(image: U8) -> tuple[U8, U8, U8]:
    """Views of the Y (H, W), U and V (H / 2, W / 2) planes of an I420 image."""
    w, h = image_size(image)
    flat = image.reshape(-1)
    quarter = (h // 2) * (w // 2)
    y = flat[: h * w].reshape(h, w)
    u = flat[h * w: h * w + quarter].reshape(h // 2, w // 2)
    v = flat[h * w + quarter:].reshape(h // 2, w // 2)
    return y, u, v


def to_bgr(image: U8) -> U8:
    """The image as BGR (itself when it already is)."""
    if pixel_format(image) == "bgr":
        return image
    return np.asarray(cv2.cvtColor(image, cv2.COLOR_YUV2BGR_I420), dtype=np.uint8)


def to_i420(image: U8) -> U8:
    """A BGR image (even width and height) as I420 (itself when it already is)."""
    if pixel_format(image) == "i420":
        return image
    h, w = image.shape[:2]
    if h % 2 or w % 2:
        raise ValueError(f"I420 needs an even width and height, got {w}x{h}")
    return np.asarray(cv2.cvtColor(image, cv2.COLOR_BGR2YUV_I420), dtype=np.uint8)
