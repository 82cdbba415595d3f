"""Benchmark of the dynamic calibration (issue 4): accuracy on the simulator's wall images, speed,
and the classic checkerboard path on the real Pose2Sim demo images.

  .venv/bin/python scripts/bench_calibration.py [--seeds 3] [--preset kinect_color] [--json OUT]
                                                [--no-checkerboard]

sim          The simulator's rendered wall images (``pipeline.sim.walls``: exact per-plane warp with
             lens distortion, supersampling, per-wall brightness, tint, vignetting, blur, noise) for
             the four default cameras (``pipeline.sim.scene.default_cameras``), one image per camera,
             for each seed. Per camera: RMS reprojection error (px), position error (mm), rotation
             error (deg), focal error (%), principal-point error (px); the median over seeds. Time:
             the whole four-camera calibration (marker detection + solve), wall clock, per seed.
checkerboard Intrinsics from the demo's real checkerboard images (``int_camXX_img``, 4x7, 60 mm):
             RMS per camera and the focal length next to the demo's Qualisys calibration.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from app.core.config import load_settings  # noqa: E402
from pipeline.calibration.checkerboard import BoardSpec, calibrate_intrinsics  # noqa: E402
from pipeline.calibration.io import load_calibration  # noqa: E402
from pipeline.calibration.patterns import make_layout  # noqa: E402
from pipeline.calibration.pnp import calibrate_cameras  # noqa: E402
from pipeline.camera import Camera  # noqa: E402
from pipeline.demo_data import fetch_demo  # noqa: E402
from pipeline.sim.scene import default_cameras  # noqa: E402
from pipeline.sim.walls import render_wall_views  # noqa: E402

TARGETS = {"rms_px": 0.3, "pos_mm": 5.0, "rot_deg": 0.1, "focal_pct": 0.3, "time_s": 5.0}


def errors(truth: Camera, solved: Camera) -> dict[str, float]:
    return {
        "pos_mm": float(np.linalg.norm(truth.center_m - solved.center_m) * 1000),
        "rot_deg": float(np.rad2deg(np.linalg.norm(cv2.Rodrigues(solved.R @ truth.R.T)[0]))),
        "focal_pct": float(np.mean([abs(solved.K[i, i] / truth.K[i, i] - 1) for i in (0, 1)]) * 100),
        "pp_px": float(np.linalg.norm(solved.K[:2, 2] - truth.K[:2, 2])),
    }


def bench_sim(seeds: int, preset: str) -> dict[str, Any]:
    settings = load_settings()
    cave = settings.cave.geometry()
    config = settings.calibration
    layout = make_layout(cave, config)
    truth = {c.name: c for c in default_cameras(cave, preset)}
    rows: dict[str, list[dict[str, float]]] = {name: [] for name in truth}
    times = []
    for seed in range(seeds):
        views = render_wall_views(cave, layout, list(truth.values()), seed=seed)
        t0 = time.perf_counter()
        results = calibrate_cameras({k: [v] for k, v in views.items()}, layout, config)
        times.append(time.perf_counter() - t0)
        for name, res in results.items():
            row = {
                "rms_px": res.rms_px,
                **errors(truth[name], res.camera),
                "markers": float(res.markers_used),
                "walls": float(len(res.walls_seen)),
            }
            rows[name].append(row)
            print(f"  seed {seed} {name}: " + "  ".join(f"{k} {v:.4g}" for k, v in row.items()))
        print(f"  seed {seed}: four-camera calibration {times[-1]:.2f} s")
    median = {name: {k: float(np.median([r[k] for r in rs])) for k in rs[0]} for name, rs in rows.items()}
    worst = {k: max(m[k] for m in median.values()) for k in ("rms_px", "pos_mm", "rot_deg", "focal_pct")}
    return {
        "preset": preset,
        "seeds": seeds,
        "per_camera_median": median,
        "worst_camera_median": worst,
        "time_s_median": float(np.median(times)),
        "time_s_max": float(max(times)),
    }


def bench_checkerboard() -> dict[str, Any]:
    demo = fetch_demo(load_settings().paths.cache_dir)
    qualisys = {c.name: c for c in load_calibration(demo.calibration)}
    out = {}
    for folder in sorted(demo.intrinsics_images.glob("int_cam*_img")):
        name = folder.name.split("_")[1]
        t0 = time.perf_counter()
        res = calibrate_intrinsics(name, [folder], BoardSpec((4, 7), 0.060))
        out[name] = {
            "rms_px": res.rms_px,
            "images_used": len(res.images_used),
            "images_skipped": len(res.images_skipped),
            "fx": float(res.camera.K[0, 0]),
            "fx_qualisys": float(qualisys[name].K[0, 0]),
            "time_s": time.perf_counter() - t0,
        }
        print(f"  {res.summary()}  (Qualisys f = {qualisys[name].K[0, 0]:.1f} px)")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--preset", default="kinect_color")
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--no-checkerboard", action="store_true")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    report: dict[str, Any] = {}
    print(f"sim: {args.seeds} seeds, four default '{args.preset}' cameras")
    report["sim"] = sim = bench_sim(args.seeds, args.preset)
    worst = sim["worst_camera_median"]
    print("sim summary (worst camera, median over seeds):")
    for key in ("rms_px", "pos_mm", "rot_deg", "focal_pct"):
        ok = "ok" if worst[key] < TARGETS[key] else "MISSED"
        print(f"  {key:10s} {worst[key]:.4f}   target < {TARGETS[key]}   {ok}")
    ok = "ok" if sim["time_s_median"] < TARGETS["time_s"] else "MISSED"
    print(f"  time_s     {sim['time_s_median']:.2f} (max {sim['time_s_max']:.2f})   target < 5   {ok}")
    if not args.no_checkerboard:
        print("checkerboard (real Pose2Sim demo images):")
        report["checkerboard"] = bench_checkerboard()
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
