"""``cavewalk tune``: measure the pose stage's variants on this machine and pick the fastest that
keeps the accuracy.

What is measured is the work of the live pipeline's steady state: the ROI crops around the
people of the real demo frames (:data:`pipeline.pose.quantize.AGREEMENT_FRAMES`, four views),
for every variant of

- precision: float32 or its int8 copy (when ``cavewalk models prepare`` kept it);
- the crop model (the head without its stride-8 level) or the full model on the crops;
- the crop size (``pose.roi_long_side``: the tallest crop network);
- onnxruntime threads per call and model calls side by side (``pose.threads``/``pose.parallel``);
- every execution provider installed that the pose stage knows (``pose.providers``).

Each variant's detections on those crops are compared with the reference, the float32 full
model on crops of the default size, by the criteria of the int8 check of ``models prepare``
(:func:`pipeline.pose.quantize.agreement_of`: the same people in every view, boxes at IoU > 0.6
and a 10th percentile > 0.95, keypoints a median < 6 px apart). The fastest variant that
passes is chosen: the lowest wall time per four-view frame in its best round (the round least
disturbed by other processes on a shared machine); ties go to the one that uses less CPU.
:func:`tuned_toml` writes it as the ``[pose]`` keys the settings load (below
``cavewalk.toml`` and ``CAVEWALK_*``, so an explicit setting wins), with the measurements and
the machine they were made on in ``[tune]``; the settings ignore the file on another machine.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.demo_data import fetch_demo
from pipeline.errors import ModelError
from pipeline.machine import machine_facts
from pipeline.pose.config import FINGERPRINT_KEYS, PROVIDERS, PoseConfig, TuneConfig
from pipeline.pose.detector import PoseDetector
from pipeline.pose.model_files import crop_model_path, pose_model_file, rejected_int8
from pipeline.pose.quantize import AGREEMENT_FRAMES, agreement_frames, agreement_of
from pipeline.pose.roi import crop_region, roi_net_size, with_margin
from pipeline.pose.types import Job

log = logging.getLogger(__name__)

@dataclass(frozen=True, slots=True)
class Variant:
    """One way to run the pose stage's crops (the ``[pose]`` keys of :data:`TUNED_KEYS`)."""

    precision: str
    crop_model: bool
    roi_long_side: int
    threads: int
    parallel: int
    provider: str = "cpu"

    def apply(self, pose: PoseConfig) -> PoseConfig:
        return replace(pose, precision=self.precision, crop_model=self.crop_model,  # type: ignore[arg-type]
                       roi_long_side=self.roi_long_side, threads=self.threads, parallel=self.parallel,
                       providers=(self.provider,))  # type: ignore[arg-type]

    def describe(self) -> str:
        lanes = (f"{self.threads or 'auto'} thread{'s' if self.threads != 1 else ''} x {self.parallel} "
                 f"lane{'s' if self.parallel > 1 else ''}")
        return (f"{self.precision}, {'crop' if self.crop_model else 'full'} model, crops up to "
                f"{self.roi_long_side} px, {lanes}, {self.provider}")


@dataclass(frozen=True, slots=True)
class Measurement:
    """A variant's time per four-view frame (ms; wall median and min over the repeats, CPU median of
    this process) and its agreement with the reference (None: not compared, it failed to run)."""

    variant: Variant
    wall_ms: float
    wall_min_ms: float
    cpu_ms: float
    ok: bool
    median_keypoint_px: float
    p10_box_iou: float
    min_box_iou: float
    failures: tuple[str, ...] = ()

    def as_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out.update(out.pop("variant"))
        out["failures"] = list(self.failures)
        for key in ("wall_ms", "wall_min_ms", "cpu_ms", "median_keypoint_px", "p10_box_iou", "min_box_iou"):
            value = float(out[key])
            out[key] = round(value, 3) if np.isfinite(value) else -1.0
        return out


@dataclass(frozen=True, slots=True)
class TuneResult:
    """The measurements, the chosen variant (None when none kept the accuracy), the machine."""

    measurements: tuple[Measurement, ...]
    chosen: Variant | None
    machine: dict[str, Any]
    providers_found: tuple[str, ...]
    frames: tuple[int, ...]
    crops_per_frame: float
    reference: str
    seconds: float
    created: str = field(default_factory=lambda: time.strftime("%Y-%m-%dT%H:%M:%S"))

    @property
    def best(self) -> Measurement | None:
        return next((m for m in self.measurements if m.variant == self.chosen), None)

    def baseline(self, pose: PoseConfig) -> Measurement | None:
        """The measurement of the variant ``pose`` runs today (threads/parallel as resolved)."""
        want = Variant(pose.precision, pose.crop_model, pose.roi_long_side, pose.intra_op_threads, pose.runs,
                       pose.providers[0])
        return next((m for m in self.measurements if m.variant == want), None)


def default_lanes(cores: int) -> tuple[tuple[int, int], ...]:
    """(threads, parallel) pairs worth measuring on ``cores`` cores."""
    out = [(1, 1)]
    if cores > 1:
        out += [(cores, 1), (1, min(cores, 4))]
    if cores >= 4:
        out.append((2, 2))
    return tuple(dict.fromkeys(out))


def installed_providers() -> tuple[str, ...]:
    """The ``pose.providers`` names whose onnxruntime execution provider is installed here."""
    import onnxruntime as ort

    available = set(ort.get_available_providers())
    return tuple(name for name, ep in PROVIDERS.items() if ep in available)


def _crop_jobs(pose: PoseConfig, boxes: Sequence[tuple[int, NDArray[np.float32]]],
               image_sizes: Sequence[tuple[int, int]]) -> list[Job]:
    """The crops ROI mode makes around ``boxes`` (image index, box) with the sizes of ``pose``."""
    jobs = []
    for i, box in boxes:
        region = with_margin(box.astype(np.float64), pose.roi_margin)
        net = roi_net_size(pose, region, image_sizes[i])
        jobs.append(Job(i, crop_region(region, image_sizes[i], net), net))
    return jobs


def tune(
    models_dir: Path,
    data_cache_dir: Path,
    pose: PoseConfig,
    config: TuneConfig = TuneConfig(),
    progress: Callable[[str], None] = log.info,
) -> TuneResult:
    """Measure the variants (see the module docstring) and choose one."""
    t_start = time.perf_counter()
    facts = machine_facts()
    demo = fetch_demo(data_cache_dir, progress=progress)
    fp32_path = pose_model_file(models_dir, "fp32")
    if not fp32_path.is_file():
        raise ModelError(f"pose model not found: {fp32_path} (run  cavewalk models prepare)")
    precisions = ["fp32"]
    int8_file = pose_model_file(models_dir, "int8")
    if int8_file.is_file():
        precisions.append("int8")
    else:
        why = rejected_int8(int8_file)
        progress("int8 not measured: "
                 + (f"models prepare did not keep it ({why})" if why else "no int8 model"))
    providers = installed_providers()
    lanes = config.lanes or default_lanes(facts.usable_cores)
    frames = [(cams, images) for cams, images in agreement_frames(demo.videos, AGREEMENT_FRAMES)]
    sizes = [[(im.shape[1], im.shape[0]) for im in images] for _, images in frames]

    # the reference: the float32 full model, on whole frames (who is there) and default-size crops
    base = replace(pose, precision="fp32", crop_model=False, providers=("cpu",))
    reference_pose = replace(PoseConfig(), parallel=1, threads=0)
    ref = PoseDetector.load(replace(reference_pose, parallel=1), fp32_path)
    try:
        people = []
        for cams, images in frames:
            found = ref.detect(images, cams, 0, 0.0)
            people.append([(i, b) for i, v in enumerate(found.views) for b in v.boxes_xyxy])
        ref_views = [ref.detect(images, cams, 0, 0.0, _crop_jobs(reference_pose, boxes, size)).views
                     for (cams, images), boxes, size in zip(frames, people, sizes, strict=True)]
    finally:
        ref.close()
    crops = sum(len(p) for p in people) / len(frames)
    progress(f"reference: float32 full model, {len(frames)} demo frames x {len(frames[0][0])} views, "
             f"{crops:.1f} crops per frame up to {reference_pose.roi_long_side} px")

    measurements: list[Measurement] = []
    agreements: dict[tuple[str, bool, int, str], Any] = {}  # the lanes do not change the detections
    for provider in providers:
        for precision in precisions:
            model = pose_model_file(models_dir, precision)  # type: ignore[arg-type]
            for crop_model in (False, True):
                if crop_model and not crop_model_path(model).is_file():
                    continue
                for k, (threads, parallel) in enumerate(lanes if provider == "cpu" else [(0, 1)]):
                    first = Variant(precision, crop_model, config.crop_sides[0], threads, parallel, provider)
                    measurements += _measure_sides(first, base, model, config, frames, people, sizes,
                                                   ref_views, agreements, progress, time_failing=k == 0)
    kept = [m for m in measurements if m.ok]
    # the fastest: the best round's wall time (the least disturbed by other processes), then CPU
    chosen = min(kept, key=lambda m: (round(m.wall_min_ms, 1), m.cpu_ms)).variant if kept else None
    return TuneResult(tuple(measurements), chosen, facts.as_dict(), providers, tuple(AGREEMENT_FRAMES), crops,
                      f"float32 full model, crops up to {reference_pose.roi_long_side} px",
                      time.perf_counter() - t_start)


def _measure_sides(first: Variant, base: PoseConfig, model: Path, config: TuneConfig,
                   frames: Sequence[tuple[list[str], list[NDArray[np.uint8]]]],
                   people: Sequence[Sequence[tuple[int, NDArray[np.float32]]]],
                   sizes: Sequence[Sequence[tuple[int, int]]], ref_views: Sequence[Any],
                   agreements: dict[tuple[str, bool, int, str], Any],
                   progress: Callable[[str], None], time_failing: bool = True) -> list[Measurement]:
    """The measurements of ``first`` at every crop size of ``config`` (one detector for all); a
    size that fails the accuracy check is timed only with ``time_failing`` (to show what it would
    save), else left out."""
    try:
        detector = PoseDetector.load(first.apply(base), model,
                                     crop_model_path(model) if first.crop_model else None)
    except ModelError as exc:
        progress(f"  {first.describe()}: does not load ({exc})")
        return []
    out = []
    try:
        for side in config.crop_sides:
            variant = replace(first, roi_long_side=side)
            cfg = variant.apply(base)
            jobs = [_crop_jobs(cfg, boxes, size) for boxes, size in zip(people, sizes, strict=True)]
            key = (variant.precision, variant.crop_model, side, variant.provider)
            views = [detector.detect(images, cams, 0, 0.0, j).views
                     for (cams, images), j in zip(frames, jobs, strict=True)]  # also the warm-up
            if key not in agreements:
                pairs = [p for r, g in zip(ref_views, views, strict=True) for p in zip(r, g, strict=True)]
                agreements[key] = agreement_of(pairs, variant.describe())
            agr = agreements[key]
            if not agr.ok and not time_failing:
                continue
            wall, wall_min, cpu = _measure(detector, frames, jobs, config.repeats)
            m = Measurement(variant, wall, wall_min, cpu, agr.ok, agr.median_keypoint_px, agr.p10_iou,
                            agr.min_iou, agr.failures)
            out.append(m)
            progress(f"  {variant.describe():<58} {m.wall_min_ms:7.1f} ms (cpu {m.cpu_ms:6.1f}) keypoints "
                     f"{m.median_keypoint_px:4.1f} px, box IoU p10 {m.p10_box_iou:.3f}  "
                     f"{'ok' if m.ok else 'FAILS the check'}")
    finally:
        detector.close()
    return out


def _measure(detector: PoseDetector, frames: Sequence[tuple[list[str], list[NDArray[np.uint8]]]],
             jobs: Sequence[list[Job]], repeats: int) -> tuple[float, float, float]:
    """(wall median, wall min, CPU median) ms per frame over ``repeats`` rounds."""
    pairs = list(zip(frames, jobs, strict=True))
    walls, cpus = [], []
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        for (cams, images), j in pairs:
            detector.detect(images, cams, 0, 0.0, j)
        walls.append((time.perf_counter() - w0) / len(frames) * 1e3)
        cpus.append((time.process_time() - c0) / len(frames) * 1e3)
    return float(np.median(walls)), float(min(walls)), float(np.median(cpus))


# ------------------------------------------------------------------------------- the tuned file
def fingerprint(machine: dict[str, Any]) -> dict[str, Any]:
    """What a tuned file must match to apply: the CPU, its cores, onnxruntime's version."""
    return {k: machine.get(k) for k in FINGERPRINT_KEYS}


def tuned_settings(result: TuneResult) -> dict[str, Any]:
    """The ``[pose]`` keys of the chosen variant ({} when none was chosen)."""
    v = result.chosen
    if v is None:
        return {}
    return {"precision": v.precision, "crop_model": v.crop_model, "roi_long_side": v.roi_long_side,
            "threads": v.threads, "parallel": v.parallel, "providers": [v.provider]}


def tuned_toml(result: TuneResult) -> str:
    """The tuned file: ``[pose]`` (what the settings load) and ``[tune]`` (how it was chosen)."""
    import tomli_w

    best = result.best
    data: dict[str, Any] = {}
    pose = tuned_settings(result)
    if pose:
        data["pose"] = pose
    data["tune"] = {
        "created": result.created,
        "machine": {k: v for k, v in result.machine.items() if v is not None},
        "fingerprint": {k: v for k, v in fingerprint(result.machine).items() if v is not None},
        "providers_found": list(result.providers_found),
        "demo_frames": list(result.frames),
        "crops_per_frame": round(result.crops_per_frame, 2),
        "reference": result.reference,
        "chosen": result.chosen.describe() if result.chosen is not None else "none kept the accuracy check",
        "chosen_ms": round(best.wall_ms, 2) if best is not None else -1.0,
        "seconds": round(result.seconds, 1),
        "measured": [m.as_dict() for m in result.measurements],
    }
    head = (f"# Written by `cavewalk tune` on {result.created} for this machine:\n"
            f"#   {result.machine.get('cpu_model')}, {result.machine.get('logical_cores')} cores, "
            f"onnxruntime {result.machine.get('onnxruntime')}\n"
            "# The settings load [pose] from here below cavewalk.toml and CAVEWALK_* variables: a key set\n"
            "# there wins. Run `cavewalk tune` again to measure afresh; delete this file to undo.\n")
    return head + tomli_w.dumps(data)
