"""What staggered views cost in accuracy, on the real demo: every view every frame against at most
N views per frame (the others carry their people, see pipeline/pose/stagger.py).

    .venv/bin/python scripts/eval_stagger.py [--frames 100] [--views 4,2,1] [--json out.json]

For each setting, over the same frames and with the same model session: the identity figures
(the subject's track id per view), the model's views per frame and inference time, the 2D
distance of the subject's keypoints to those of the every-view run (median / p95 px, keypoints
that run is sure of), the 3D joints triangulated with the demo calibration against those of the
every-view run (median / p95 mm), the reprojection error the reconstructor reports (median px)
and the 3D people's ids. The CPU and the load average are printed with the figures.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from app.core.config import get_settings
from pipeline.calibration.io import load_calibration
from pipeline.demo_data import fetch_demo
from pipeline.machine import machine_facts
from pipeline.pose.detector import PoseDetector
from pipeline.pose.roi import RoiScheduler
from pipeline.runtime.offline import SyncedVideos
from pipeline.tracking.benchmark import view_figures
from pipeline.tracking.ocsort import MultiViewTracker
from pipeline.tracking.stage import DetectAndTrack
from pipeline.triangulation.config import ReconstructionConfig
from pipeline.triangulation.reconstructor import Reconstructor

SURE = 0.5


def run(views_per_frame: int, frames: int, detector: PoseDetector, videos: dict[str, Path],
        cameras: list, settings) -> dict:
    pose = replace(settings.pose, views_per_frame=views_per_frame)
    recon = Reconstructor(cameras, ReconstructionConfig(settings.triangulation, settings.association,
                                                        settings.tracks3d))
    out = {"views": [], "people": [], "detected": [], "infer_ms": [], "step_ms": []}
    with SyncedVideos(videos) as synced:
        cams = list(synced.cameras)
        stage = DetectAndTrack(detector, MultiViewTracker(cams, settings.tracking), RoiScheduler(pose))
        for k, images in enumerate(synced):
            if k >= frames:
                break
            t0 = time.perf_counter()
            tracked, t = stage.step(images, k, k / synced.fps)
            out["step_ms"].append((time.perf_counter() - t0) * 1e3)
            out["views"].append(tracked)
            out["people"].append(recon.update(tracked, k / synced.fps))
            out["detected"].append(t.detected_views)
            out["infer_ms"].append(t.inference_s * 1e3)
    return out


def subject(view) -> tuple[int, np.ndarray, np.ndarray] | None:
    det = view.detections
    if len(view) == 0:
        return None
    b = view.boxes_xyxy
    i = int(np.argmax((b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])))
    return int(view.track_ids[i]), view.keypoints_xy[i], view.keypoint_scores[i] if det is not None else None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--views", default="4,2,1", help="views per frame to compare (the first: the reference)")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    settings = get_settings()
    demo = fetch_demo(settings.paths.cache_dir)
    cameras = load_calibration(demo.calibration)
    model = settings.pose_model_path
    detector = PoseDetector.load(settings.pose, model, settings.pose.crop_model_file(model))
    settings_views = [int(v) for v in args.views.split(",")]
    print(f"machine: {machine_facts().summary()}; load average {os.getloadavg()[0]:.1f}; model {model.name}")
    runs = {v: run(v, args.frames, detector, demo.videos, cameras, settings) for v in settings_views}
    ref = runs[settings_views[0]]
    report = {}
    for v, r in runs.items():
        d2, d3, reproj = [], [], []
        ids3d: dict[int, int] = {}
        for fv, rv, fp, rp in zip(r["views"], ref["views"], r["people"], ref["people"], strict=True):
            for a, b in zip(fv, rv, strict=True):
                sa, sb = subject(a), subject(b)
                if sa is None or sb is None:
                    continue
                sure = sb[2] >= SURE
                d2 += np.linalg.norm(sa[1][sure] - sb[1][sure], axis=1).tolist()
            for p in fp:
                ids3d[p.user_id] = ids3d.get(p.user_id, 0) + 1
                if np.isfinite(p.reproj_px):
                    reproj.append(p.reproj_px)
            theirs = {p.user_id: p for p in rp}
            for a in fp:  # the same 3D person (the ids hold in both runs: checked by people_3d_ids)
                b = theirs.get(a.user_id)
                if b is not None:
                    both = a.joint_valid & b.joint_valid
                    d3 += (np.linalg.norm(a.joints_m[both] - b.joints_m[both], axis=1) * 1e3).tolist()
        cams = [view.camera for view in r["views"][0]]
        figs = [view_figures(c, [f[i] for f in r["views"]]) for i, c in enumerate(cams)]
        row = {
            "views_per_frame": v,
            "detected_views_per_frame": float(np.mean(r["detected"])),
            "inference_ms_median": float(np.median(r["infer_ms"])),
            "step_ms_median": float(np.median(r["step_ms"])),
            "subject_ids": {f.camera: f.subject_ids for f in figs},
            "keypoints_2d_px": {"median": float(np.median(d2)) if d2 else None,
                                "p95": float(np.percentile(d2, 95)) if d2 else None},
            "joints_3d_mm": {"median": float(np.median(d3)) if d3 else None,
                             "p95": float(np.percentile(d3, 95)) if d3 else None},
            "reprojection_px_median": float(np.median(reproj)) if reproj else None,
            "people_3d_ids": ids3d,
        }
        report[v] = row
        k2, k3 = row["keypoints_2d_px"], row["joints_3d_mm"]
        print(f"views/frame {v} (model on {row['detected_views_per_frame']:.2f}): inference "
              f"{row['inference_ms_median']:.1f} ms, step {row['step_ms_median']:.1f} ms median; "
              f"against every view: 2D {k2['median'] or 0:.1f} / {k2['p95'] or 0:.1f} px (median / p95), "
              f"3D {k3['median'] or 0:.1f} / {k3['p95'] or 0:.1f} mm; reprojection "
              f"{row['reprojection_px_median'] or float('nan'):.1f} px; 3D ids {ids3d}")
        for f in figs:
            print(f"    {f.camera}: subject ids {f.subject_ids}, others {f.other_ids}, "
                  f"keypoints in {f.keypoint_frames}/{f.frames}")
    print(f"load average at the end {os.getloadavg()[0]:.1f}")
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
