"""Region-of-interest mode: run the pose model on crops around tracked people.

Once people are tracked in a view, the next frame only needs to look where the
tracker expects them. Each expected box (plus a margin) becomes a crop; people close
together share one. The crops of all views go into one batch at one small network size
(``long_side`` high, as wide as the widest crop needs). A full-frame pass runs every
``full_every`` frames (to find people who walk in) and right after a tracked person was
not found in their crop. A view with no track is looked at whole, at the crop size.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from pipeline.pose.preprocess import expand_to_aspect, net_size_for

Region = tuple[float, float, float, float]


class RoiSettingsLike(Protocol):
    """The fields of ``app.core.config.PoseSettings`` read here."""

    @property
    def roi(self) -> bool: ...
    @property
    def roi_long_side(self) -> int: ...
    @property
    def roi_margin(self) -> float: ...
    @property
    def roi_full_every(self) -> int: ...


@dataclass(frozen=True, slots=True)
class RoiConfig:
    """enabled: use crops at all. long_side: crop network height, px (multiple of 32).
    margin: crop margin on each side, as a fraction of the expected box's larger side.
    full_every: a full-frame pass at least every this many frames.
    max_crops: more crops than this in a frame -> full frame instead.
    min_aspect, max_aspect: bounds of the crop aspect w / h; within them a frame's crops
    take the widest box-plus-margin aspect (so a person with arms out is not shrunk).
    merge_growth: two people of a view share one crop when their union is at most this
    many times the larger one's area."""

    enabled: bool = True
    long_side: int = 320
    margin: float = 0.1
    full_every: int = 30
    max_crops: int = 12
    min_aspect: float = 0.4
    max_aspect: float = 1.0
    merge_growth: float = 1.3

    def __post_init__(self) -> None:
        if self.long_side <= 0 or self.long_side % 32:
            raise ValueError(f"long_side must be a positive multiple of 32, got {self.long_side}")
        if self.margin < 0 or self.full_every < 1 or self.max_crops < 1:
            raise ValueError(
                f"need margin >= 0, full_every >= 1, max_crops >= 1; got {self.margin}, "
                f"{self.full_every}, {self.max_crops}")
        if self.merge_growth < 1:
            raise ValueError(f"merge_growth must be >= 1, got {self.merge_growth}")
        if not 0 < self.min_aspect <= self.max_aspect:
            raise ValueError(f"need 0 < min_aspect <= max_aspect, got {self.min_aspect}, {self.max_aspect}")

    @classmethod
    def from_settings(cls, pose: RoiSettingsLike) -> RoiConfig:
        return cls(enabled=bool(pose.roi), long_side=int(pose.roi_long_side), margin=float(pose.roi_margin),
                   full_every=int(pose.roi_full_every))

    def net_size(self, regions: Sequence[Region]) -> tuple[int, int]:
        """Network (w, h) for a batch of crops of these regions (margins included): height
        ``long_side``, width for the widest region (within the aspect bounds)."""
        aspect = self.min_aspect
        for x1, y1, x2, y2 in regions:
            aspect = max(aspect, (x2 - x1) / max(y2 - y1, 1.0))
        return net_size_for(min(aspect, self.max_aspect), self.long_side)


def with_margin(box_xyxy: NDArray[np.float64] | Region, margin: float) -> Region:
    """The box grown by ``margin`` x its larger side on every side."""
    x1, y1, x2, y2 = (float(v) for v in box_xyxy[:4])
    pad = margin * max(x2 - x1, y2 - y1)
    return x1 - pad, y1 - pad, x2 + pad, y2 + pad


def _area(r: Region) -> float:
    return max(r[2] - r[0], 0.0) * max(r[3] - r[1], 0.0)


def merge_regions(regions: Sequence[Region], max_growth: float) -> list[Region]:
    """Merge regions of one view whose union is at most ``max_growth`` x the larger one's
    area (close or overlapping people share a crop: one batch slot, little resolution lost)."""
    out = list(regions)
    merged = True
    while merged and len(out) > 1:
        merged = False
        for i in range(len(out)):
            for j in range(i + 1, len(out)):
                a, b = out[i], out[j]
                u = (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3]))
                if _area(u) <= max_growth * max(_area(a), _area(b)):
                    out[i] = u
                    del out[j]
                    merged = True
                    break
            if merged:
                break
    return out


@dataclass(frozen=True, slots=True)
class RoiPlan:
    """What the detector runs for one frame: jobs (image index, region or None) and the network size.

    full: True for a full-frame pass (net_size None = the detector's full-frame size).
    """

    full: bool
    jobs: tuple[tuple[int, Region | None], ...]
    net_size: tuple[int, int] | None
    reason: str


def crop_region(region: Region, image_size: tuple[int, int], net_size: tuple[int, int]) -> Region:
    """The crop for a region (margins included): grown to the aspect of ``net_size`` around its
    centre, kept within the image where it fits (a crop larger than the image is centred on it)."""
    net_w, net_h = net_size
    x1, y1, x2, y2 = expand_to_aspect(region, net_w / net_h)
    w, h = image_size
    out = []
    for lo, hi, size in ((x1, x2, w), (y1, y2, h)):
        span = hi - lo
        lo = (size - span) / 2.0 if span >= size else min(max(lo, 0.0), size - span)
        out.append((lo, lo + span))
    (x1, x2), (y1, y2) = out
    return x1, y1, x2, y2


def _contains(outer: Region, inner: Region) -> bool:
    return outer[0] <= inner[0] and outer[1] <= inner[1] and outer[2] >= inner[2] and outer[3] >= inner[3]


class RoiScheduler:
    """Decides per frame between a full-frame pass and crops around the expected boxes.

    Crops are kept still while the people stay inside them (a crop moving with every
    frame resamples the image differently each time, which shows as keypoint jitter),
    and the crop network size only shrinks when it would save a whole 64 px column.
    """

    def __init__(self, config: RoiConfig) -> None:
        self.config = config
        self._since_full: int | None = None  # frames since the last full pass; None = never
        self._lost = False
        self._net: tuple[int, int] | None = None
        self._crops: dict[int, list[Region]] = {}  # view -> the crops of the last ROI frame

    def report(self, full: bool, lost_track: bool) -> None:
        """After a frame: was it a full pass, and did a confirmed track go unmatched?"""
        self._since_full = 0 if full else (self._since_full or 0) + 1
        self._lost = lost_track
        if full:
            self._crops.clear()

    def _stable_net(self, wanted: tuple[int, int]) -> tuple[int, int]:
        last = self._net
        if last is not None and last[1] == wanted[1] and wanted[0] <= last[0] < wanted[0] + 64:
            return last
        self._net = wanted
        return wanted

    def _stable_crop(self, view: int, region: Region, image_size: tuple[int, int],
                     net_size: tuple[int, int]) -> Region:
        fresh = crop_region(region, image_size, net_size)
        aspect = net_size[0] / net_size[1]
        for old in self._crops.get(view, ()):
            w, h = old[2] - old[0], old[3] - old[1]
            if (_contains(old, region) and abs(w / h - aspect) < 1e-6
                    and h <= 1.15 * (fresh[3] - fresh[1])):
                return old
        return fresh

    def plan(self, image_sizes: Sequence[tuple[int, int]],
             expected: Sequence[Mapping[int, NDArray[np.float64]]]) -> RoiPlan:
        """expected[i]: track id -> box the tracker expects in image i this frame."""
        cfg = self.config
        full = RoiPlan(True, tuple((i, None) for i in range(len(image_sizes))), None, "")
        if not cfg.enabled:
            return RoiPlan(True, full.jobs, None, "roi off")
        if self._since_full is None:
            return RoiPlan(True, full.jobs, None, "first frame")
        if self._since_full + 1 >= cfg.full_every:
            return RoiPlan(True, full.jobs, None, "periodic")
        if self._lost:
            return RoiPlan(True, full.jobs, None, "track lost")
        if not any(expected):
            return RoiPlan(True, full.jobs, None, "nobody tracked")
        regions = [
            merge_regions([with_margin(boxes[t], cfg.margin) for t in sorted(boxes)], cfg.merge_growth)
            for boxes in expected
        ]
        net_size = self._stable_net(cfg.net_size([r for rs in regions for r in rs]))
        jobs: list[tuple[int, Region | None]] = []
        crops: dict[int, list[Region]] = {}
        for i, rs in enumerate(regions):
            if not rs:
                jobs.append((i, None))  # the whole view, at crop size
            crops[i] = [self._stable_crop(i, r, image_sizes[i], net_size) for r in rs]
            jobs.extend((i, c) for c in crops[i])
        if len(jobs) > cfg.max_crops:
            return RoiPlan(True, full.jobs, None, "too many crops")
        self._crops = crops
        return RoiPlan(False, tuple(jobs), net_size, "roi")
