"""Benchmark and quality figures of detection + tracking over synchronised videos.

:func:`run_detect_benchmark` times :class:`DetectAndTrack` frame by frame (video decoding
excluded) and reports the median per multi-view frame with its split into
pre-processing, inference, decoding and tracking, plus figures on identity: which track
id the main subject (the largest person of a view) had in each frame, the ids of the
others, and how often the subject's keypoints were found. ``scripts/bench_detect.py``
and ``cavewalk bench --stage detect`` call :func:`bench_demo`.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.demo_data import fetch_demo
from pipeline.errors import InputError
from pipeline.pose.config import PoseConfig
from pipeline.pose.detector import PoseDetector
from pipeline.pose.roi import RoiScheduler
from pipeline.runtime.offline import SyncedVideos
from pipeline.tracking.ocsort import MultiViewTracker, OCSortConfig
from pipeline.tracking.stage import DetectAndTrack, StepTimings
from pipeline.tracking.types import TrackedView

log = logging.getLogger(__name__)

MIN_KEYPOINTS = 12  # a subject "has keypoints" in a view-frame with this many ...
KEYPOINT_SCORE = 0.5  # ... keypoints scored at least this


@dataclass(frozen=True, slots=True)
class ViewFigures:
    """Identity figures of one camera over a run.

    subject_ids: track id -> frames in which the view's largest person had that id
        (0 = the largest person was not reported by the tracker).
    other_ids: track id -> frames, for everyone else.
    keypoint_frames: frames in which the subject had >= MIN_KEYPOINTS keypoints scored >= KEYPOINT_SCORE.
    """

    camera: str
    frames: int
    subject_ids: dict[int, int]
    other_ids: dict[int, int]
    keypoint_frames: int


@dataclass(frozen=True, slots=True)
class DetectBenchResult:
    """One run (full-frame or ROI mode); times in milliseconds per multi-view frame.
    full_frames: frames with every view whole at the full-frame size; full_views: views
    looked at whole at that size, all frames together (ROI mode does them one at a time)."""

    mode: str
    frames: int
    views: int
    median_ms: float
    mean_ms: float
    p90_ms: float
    preprocess_ms: float
    inference_ms: float
    decode_ms: float
    tracking_ms: float
    full_frames: int
    full_views: int
    figures: tuple[ViewFigures, ...]
    detected_views: int = 0  # views the model looked at, all frames together (staggered: fewer)

    @property
    def keypoint_coverage(self) -> float:
        total = sum(f.frames for f in self.figures)
        return sum(f.keypoint_frames for f in self.figures) / total if total else float("nan")

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["keypoint_coverage"] = self.keypoint_coverage
        return d


def view_figures(camera: str, views: list[TrackedView]) -> ViewFigures:
    """Identity figures of one camera from its per-frame tracked views."""
    subject: Counter[int] = Counter()
    others: Counter[int] = Counter()
    kp_frames = 0
    for v in views:
        det = v.detections
        if len(det) == 0:
            subject[0] += 1
            continue
        b = det.boxes_xyxy
        largest = int(np.argmax((b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])))
        rows = v.detection_index.tolist()
        ids = v.track_ids.tolist()
        tid = ids[rows.index(largest)] if largest in rows else 0
        subject[tid] += 1
        others.update(t for t, r in zip(ids, rows, strict=True) if r != largest)
        if tid and int((det.keypoint_scores[largest] >= KEYPOINT_SCORE).sum()) >= MIN_KEYPOINTS:
            kp_frames += 1
    return ViewFigures(camera, len(views), dict(subject), dict(others), kp_frames)


def summarise(
    mode: str, timings: list[StepTimings], per_camera: Mapping[str, list[TrackedView]]
) -> DetectBenchResult:
    tot = np.array([t.total_s for t in timings]) * 1e3

    def med(name: str) -> float:
        return float(np.median([getattr(t, name) for t in timings]) * 1e3)

    return DetectBenchResult(
        mode=mode, frames=len(timings), views=len(per_camera),
        median_ms=float(np.median(tot)), mean_ms=float(np.mean(tot)), p90_ms=float(np.percentile(tot, 90)),
        preprocess_ms=med("preprocess_s"), inference_ms=med("inference_s"), decode_ms=med("decode_s"),
        tracking_ms=med("tracking_s"), full_frames=sum(t.full for t in timings),
        full_views=sum(t.full_views for t in timings),
        figures=tuple(view_figures(c, v) for c, v in per_camera.items()),
        detected_views=sum(t.detected_views for t in timings),
    )


def run_detect_benchmark(
    videos: Mapping[str, Path],
    make_stage: Callable[[list[str]], DetectAndTrack],
    mode: str,
    frames: int | None = None,
    progress: Callable[[int], None] | None = None,
) -> DetectBenchResult:
    """Run detection + tracking over the videos; ``make_stage(cameras)`` builds a fresh stage."""
    per_camera: dict[str, list[TrackedView]] = {}
    timings: list[StepTimings] = []
    with SyncedVideos(videos) as synced:
        cams = list(synced.cameras)
        stage = make_stage(cams)
        per_camera = {c: [] for c in cams}
        fps = synced.fps
        for k, images in enumerate(synced):
            if frames is not None and k >= frames:
                break
            tracked, t = stage.step(images, k, k / fps)
            timings.append(t)
            for v in tracked:
                per_camera[v.camera].append(v)
            if progress is not None:
                progress(k + 1)
    return summarise(mode, timings, per_camera)


def format_results(results: list[DetectBenchResult]) -> str:
    """A side-by-side table of the runs and their identity figures."""
    lines = [f"{'mode':<10}{'frames':>7}{'median ms':>11}{'mean ms':>9}{'p90 ms':>9}{'pre':>8}{'infer':>8}"
             f"{'decode':>8}{'track':>8}{'full views':>12}{'kp cover':>10}{'views/frame':>12}"]
    for r in results:
        lines.append(f"{r.mode:<10}{r.frames:>7}{r.median_ms:>11.1f}{r.mean_ms:>9.1f}{r.p90_ms:>9.1f}"
                     f"{r.preprocess_ms:>8.1f}{r.inference_ms:>8.1f}{r.decode_ms:>8.1f}{r.tracking_ms:>8.2f}"
                     f"{r.full_views:>12}{100 * r.keypoint_coverage:>9.1f}%"
                     f"{r.detected_views / max(r.frames, 1):>12.2f}")
    for r in results:
        for f in r.figures:
            lines.append(f"  {r.mode:<8} {f.camera}: subject ids {f.subject_ids}, others {f.other_ids}, "
                         f"keypoints in {f.keypoint_frames}/{f.frames}")
    return "\n".join(lines)


def bench_demo(
    pose: PoseConfig,
    tracking: OCSortConfig,
    model_path: Path,
    cache_dir: Path,
    frames: int | None = 100,
    repeat: int = 1,
    threads: int | None = None,
    modes: tuple[str, ...] = ("full", "roi"),
    spinning: bool = False,
    parallel: int | None = None,
    views_per_frame: int | None = None,
) -> list[DetectBenchResult]:
    """Full-frame and ROI runs on the real demo (fetched like ``cavewalk data demo``), one model
    session for all; the best median of ``repeat`` runs per mode (other processes share the CPU).
    threads, parallel, views_per_frame: override ``pose.threads`` / ``pose.parallel`` /
    ``pose.views_per_frame`` (staggered views, :mod:`pipeline.pose.stagger`)."""
    unknown = set(modes) - {"full", "roi"}
    if unknown:
        raise InputError(f"unknown benchmark modes {sorted(unknown)}; use full and/or roi")
    demo = fetch_demo(cache_dir)
    config = replace(pose, spinning=spinning)
    if threads is not None:
        config = replace(config, threads=threads)
    if parallel is not None:
        config = replace(config, parallel=parallel)
    if views_per_frame is not None:
        config = replace(config, views_per_frame=views_per_frame)
    detector = PoseDetector.load(config, model_path, config.crop_model_file(model_path))
    results = []
    for mode in modes:
        roi_cfg = replace(config, roi=mode == "roi")

        def make(cams: list[str], roi_cfg: PoseConfig = roi_cfg) -> DetectAndTrack:
            return DetectAndTrack(detector, MultiViewTracker(cams, tracking), RoiScheduler(roi_cfg))

        runs = [run_detect_benchmark(demo.videos, make, mode, frames) for _ in range(max(1, repeat))]
        results.append(min(runs, key=lambda r: r.median_ms))
    return results
