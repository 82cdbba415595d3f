"""Region-of-interest mode: run the pose model on crops around tracked people.

Once people are tracked in a view, the next frame only needs to look where the
tracker expects them. Each expected box (plus a margin) becomes a crop; people close
together share one. Every crop gets its own network size: as tall as the crop needs to
be sampled as finely as the full-frame pass samples the image (at most ``long_side``),
as wide as the person needs. A person far from the camera costs a small crop, not a
big one. The detector batches crops of equal size together.

Full-frame passes (the whole view at the full network size) happen on a view's first
frame and whenever nobody is tracked anywhere. Otherwise a view is *looked at* whole at
the crop size, beside its crops (which keep the tracked people's finer keypoints): right
after a tracked person was not found in their crop, and every ``full_every`` frames to
find people who walk in. The periodic looks are staggered over the views (at most one
per frame), so no frame pays for all views at once. A view with no track while others
have some is looked at whole at the crop size every frame.
"""

from __future__ import annotations

from collections.abc import Collection, Hashable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.pose.config import PoseConfig
from pipeline.pose.preprocess import STRIDE, expand_to_aspect, net_size_for, round_up
from pipeline.pose.types import Job, Region


def roi_net_size(config: PoseConfig, region: Region, image_size: tuple[int, int]) -> tuple[int, int]:
    """Network (w, h) for a crop of ``region`` (margins included) of an image of ``image_size``:
    height for the whole-view pass's sampling (within ``crop_min_side``..``roi_long_side``; a
    small person gets a small crop), width for the region's aspect (within the aspect bounds)."""
    x1, y1, x2, y2 = region
    w, h = max(x2 - x1, 1.0), max(y2 - y1, 1.0)
    full_scale = config.input_long_side / max(image_size)
    net_h = min(max(round_up(h * full_scale), config.crop_min_side), config.roi_long_side)
    aspect = min(max(w / h, config.roi_min_aspect), config.roi_max_aspect)
    return net_size_for(aspect, net_h)


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
    """What the detector runs for one frame.

    jobs: (image index, region or None for the whole image, network size or None for the
        detector's full-frame size).
    full_views: indices of the images looked at whole at the full-frame size.
    reason: why those views were (``"roi"`` when none was).
    """

    jobs: tuple[Job, ...]
    full_views: frozenset[int]
    reason: str
    detected: frozenset[int] | None = None  # the views with jobs (None: all)

    @property
    def full(self) -> bool:
        """Every image whole at the full-frame size (no crop at all)."""
        return all(j.region is None and j.net_size is None for j in self.jobs)


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
    """Decides per frame and view between a full-frame pass and crops around the expected boxes.

    Views are named by the keys given to :meth:`plan` (camera names; image indices by
    default), so a camera missing from a frame keeps its state. Crops are kept still
    while the people stay inside them (a crop moving with every frame resamples the image
    differently each time, which shows as keypoint jitter).
    """

    def __init__(self, config: PoseConfig) -> None:
        self.config = config
        self._since_full: dict[Hashable, int] = {}  # view -> frames since it was last seen whole
        self._lost: set[Hashable] = set()
        self._crops: dict[Hashable, list[tuple[Region, tuple[int, int]]]] = {}  # view -> (crop, net)
        self._planned: tuple[list[Hashable], frozenset[int], frozenset[int]] | None = None

    def attention(self, views: Sequence[Hashable]) -> set[int]:
        """Indices of the views (keys) that need the model this frame: new ones, and those where a
        tracked person went unmatched last time (:mod:`pipeline.pose.stagger` detects them first)."""
        return {i for i, k in enumerate(views) if k not in self._since_full or k in self._lost}

    def report(self, lost: Collection[Hashable] = ()) -> None:
        """After the frame last planned: the views (keys) where a tracked person went unmatched."""
        if self._planned is None:
            raise RuntimeError("report() without a plan() before it")
        keys, full_views, looked = self._planned
        self._planned = None
        everything = len(full_views) == len(keys)
        for rank, key in enumerate(keys):
            if rank in full_views:
                # after a pass of every view at once, stagger their next periodic looks
                self._since_full[key] = (rank * self.config.roi_full_every) // len(keys) if everything else 0
                self._crops.pop(key, None)
            elif rank in looked:
                self._since_full[key] = 0
            else:
                self._since_full[key] = self._since_full.get(key, 0) + 1
        self._lost = set(keys) & set(lost)

    def _stable_crop(self, key: Hashable, region: Region, image_size: tuple[int, int]
                     ) -> tuple[Region, tuple[int, int]]:
        net = roi_net_size(self.config, region, image_size)
        fresh = crop_region(region, image_size, net)
        for old, old_net in self._crops.get(key, ()):
            if (_contains(old, region) and old_net[1] == net[1] and old_net[0] < net[0] + 2 * STRIDE
                    and old[3] - old[1] <= 1.15 * (fresh[3] - fresh[1])):
                return old, old_net
        return fresh, net

    def plan(self, image_sizes: Sequence[tuple[int, int]],
             expected: Sequence[Mapping[int, NDArray[np.float64]]],
             views: Sequence[Hashable] | None = None, detect: Collection[int] | None = None) -> RoiPlan:
        """expected[i]: track id -> box the tracker expects in image i this frame; views[i]: its key;
        detect: the indices of the images the model looks at (None: all; a first frame, or one with
        nobody tracked, looks at all whatever it says)."""
        cfg = self.config
        keys: list[Hashable] = list(views) if views is not None else list(range(len(image_sizes)))
        if len(keys) != len(image_sizes) or len(expected) != len(image_sizes):
            raise ValueError(f"need one size, expectation and key per image, got {len(image_sizes)}, "
                             f"{len(expected)}, {len(keys)}")
        everything = frozenset(range(len(keys)))

        def whole(reason: str) -> RoiPlan:
            self._planned = (keys, everything, everything)
            return RoiPlan(tuple(Job(i) for i in range(len(keys))), everything, reason)

        if not cfg.roi:
            return whole("roi off")
        if all(k not in self._since_full for k in keys):
            return whole("first frame")
        if not any(expected):
            return whole("nobody tracked")
        full: dict[int, str] = {}
        looks: dict[int, str] = {}
        chosen = everything if detect is None else frozenset(detect) & everything
        for i, key in enumerate(keys):
            if i not in chosen:
                continue
            if key not in self._since_full:
                full[i] = "new view"
            elif key in self._lost:  # a look at the whole view beside the crops finds them again
                looks[i] = "track lost"
        due = [(self._since_full[k], i) for i, k in enumerate(keys)
               if i in chosen and i not in full and i not in looks
               and self._since_full[k] + 1 >= cfg.roi_full_every]
        if due:
            looks[max(due)[1]] = "look for newcomers"  # the most overdue view; the others wait a frame
        jobs: list[Job] = []
        crops: dict[Hashable, list[tuple[Region, tuple[int, int]]]] = {}
        for i, (key, boxes) in enumerate(zip(keys, expected, strict=True)):
            if i not in chosen:
                continue
            if i in full:
                jobs.append(Job(i))
                continue
            size = image_sizes[i]
            coarse = Job(i, None, net_size_for(size[0] / size[1], cfg.roi_long_side))
            if not boxes:  # nobody here while others have people: whole, at the crop size
                jobs.append(coarse)
                continue
            if i in looks:
                jobs.append(coarse)
            regions = merge_regions([with_margin(boxes[t], cfg.roi_margin) for t in sorted(boxes)],
                                    cfg.roi_merge_growth)
            crops[key] = [self._stable_crop(key, r, size) for r in regions]
            jobs.extend(Job(i, crop, net) for crop, net in crops[key])
        if len(jobs) > cfg.roi_max_crops:
            return whole("too many crops")
        self._crops.update(crops)
        self._planned = (keys, frozenset(full), frozenset(full) | frozenset(looks))
        reasons = sorted(set(full.values()) | set(looks.values()))
        return RoiPlan(tuple(jobs), frozenset(full), ", ".join(reasons) if reasons else "roi",
                       None if chosen == everything else chosen)
