"""Benchmark of the triangulation stage (issue 6): accuracy on the simulator and on real video, speed.

  .venv/bin/python scripts/bench_triangulation.py [--section sim|demo|speed|all] [--json OUT]

sim    Simulator, four ``kinect_color`` cameras (one above each wall), the simulator's realistic 2D
       faults (size-scaled pixel noise per COCO sigma, occlusion by the body, low-score guesses for
       hidden joints, dropouts, ghost detections): MPJPE (mm) of the reconstructed skeleton against
       the ground truth, per floor cell of a 6 x 6 grid over the 3 m x 3 m CAVE floor.
demo   Pose2Sim Demo_SinglePerson (real video, 4 views, Qualisys calibration): the real pose model
       (yolo11n-pose ONNX) + OC-SORT + this stage; mean reprojection error (px) of the triangulated
       joints and the frame-to-frame std of thigh and shin lengths; side by side, on the very same
       2D keypoints, aniposelib's ``CameraGroup.triangulate`` if aniposelib can be imported
       (install it outside the project: ``pip install --no-deps --target /tmp/anipose aniposelib
       numba llvmlite toml`` and run with ``PYTHONPATH=/tmp/anipose``); the column is skipped if not.
speed  Per person-frame time of ``triangulate`` for 17 joints x 4 views (undistortion included), and
       of the whole ``Reconstructor.update`` with 1 and 4 people.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pipeline.camera import Camera  # noqa: E402
from pipeline.skeleton import J  # noqa: E402
from pipeline.tracking.types import TrackedView  # noqa: E402
from pipeline.triangulation.config import ReconstructionConfig, Tracks3DParams  # noqa: E402
from pipeline.triangulation.dlt import CameraRig, reprojection_error, triangulate  # noqa: E402
from pipeline.triangulation.reconstructor import Reconstructor, person_size_px  # noqa: E402

RAW = ReconstructionConfig(tracks=Tracks3DParams(smoothing="none"))
SMOOTH = ReconstructionConfig()
LEGS = {
    "l_thigh": ("l_hip", "l_knee"),
    "r_thigh": ("r_hip", "r_knee"),
    "l_shin": ("l_knee", "l_ankle"),
    "r_shin": ("r_knee", "r_ankle"),
}


def _say(msg: str) -> None:
    print(msg, flush=True)


# ------------------------------------------------------------------------------------------ sim


def bench_sim(
    seconds: float,
    seed: int,
    action_weights: dict[str, float] | None = None,
    cameras: list[Camera] | None = None,
) -> dict[str, Any]:
    """MPJPE by floor cell; ``action_weights`` = what the people do (default: the four actions evenly);
    ``cameras`` = the simulator's cameras (default: four ``kinect_color`` above the walls)."""
    from pipeline.cave import box_cave
    from pipeline.sim.body import sample_body
    from pipeline.sim.motion import simulate_user
    from pipeline.sim.scene import default_cameras
    from pipeline.sim.script import random_script
    from pipeline.sim.views import FaultConfig, observe_with_ids

    cave = box_cave()
    cams = cameras or default_cameras(cave, "kinect_color", 4)
    faults = FaultConfig()
    centres = np.array([-1.25, -0.75, -0.25, 0.25, 0.75, 1.25])
    fps = 30.0
    rng = np.random.default_rng(seed)
    table = {"raw": np.full((6, 6), np.nan), "one_euro": np.full((6, 6), np.nan)}
    valid_frac = np.full((6, 6), np.nan)
    per_cell_errors: dict[str, list[float]] = {"raw_centre": [], "euro_centre": []}
    t0 = time.perf_counter()
    for iy, y in enumerate(centres[::-1]):
        for ix, x in enumerate(centres):
            start = (float(x + rng.uniform(-0.15, 0.15)), float(y + rng.uniform(-0.15, 0.15)))
            script = random_script(
                rng,
                seconds,
                start_xy_m=start,
                action_weights=action_weights or {"still": 1, "forward": 1, "left": 1, "right": 1},
            )
            motion = simulate_user(script, sample_body(rng), fps=fps, seed=int(rng.integers(1 << 30)))
            recs = {"raw": Reconstructor(cams, RAW), "one_euro": Reconstructor(cams, SMOOTH)}
            errs: dict[str, list[float]] = {"raw": [], "one_euro": []}
            n_valid = n_total = 0
            for f in range(len(motion)):
                truth = motion.joints_m[f]
                obs = observe_with_ids(cams, [truth], f, f / fps, rng, faults)
                views = [
                    TrackedView(v, np.where(ids >= 0, ids + 1, 1000 + np.arange(len(ids))), np.arange(len(v)))
                    for v, ids in obs
                ]
                for name, rec in recs.items():
                    people = rec.update(views, f / fps)
                    if not people:
                        if name == "raw":
                            n_total += 17
                        continue
                    p = min(
                        people, key=lambda q: float(np.nanmean(np.linalg.norm(q.joints_m - truth, axis=1)))
                    )
                    e = np.linalg.norm(p.joints_m - truth, axis=1)[p.joint_valid]
                    errs[name].extend(e.tolist())
                    if name == "raw":
                        n_valid += int(p.joint_valid.sum())
                        n_total += 17
            for name in errs:
                table[name][iy, ix] = 1000 * float(np.mean(errs[name])) if errs[name] else np.nan
            valid_frac[iy, ix] = n_valid / max(n_total, 1)
            if abs(x) < 1.0 and abs(y) < 1.0:
                per_cell_errors["raw_centre"].extend(errs["raw"])
                per_cell_errors["euro_centre"].extend(errs["one_euro"])
    elapsed = time.perf_counter() - t0
    centre_raw = 1000 * float(np.mean(per_cell_errors["raw_centre"]))
    centre_euro = 1000 * float(np.mean(per_cell_errors["euro_centre"]))
    r = np.hypot(*np.meshgrid(centres, centres[::-1]))
    rings = {
        "centre 1x1 m": r < 0.5,
        "central 2x2 m (excl. centre)": (np.maximum(*np.meshgrid(np.abs(centres), np.abs(centres[::-1]))) < 1)
        & (r >= 0.5),
        "outer ring (edges)": (np.maximum(*np.meshgrid(np.abs(centres), np.abs(centres[::-1]))) > 1)
        & ~((np.abs(np.meshgrid(centres, centres)[0]) > 1) & (np.abs(np.meshgrid(centres, centres)[1]) > 1)),
        "corners": (np.abs(np.meshgrid(centres, centres)[0]) > 1)
        & (np.abs(np.meshgrid(centres, centres)[1]) > 1),
    }
    _say(
        f"\n== (a) simulator: 4 kinect_color cameras, default faults, {seconds:.0f} s per cell at 30 fps "
        f"({elapsed:.0f} s) =="
    )
    _say("MPJPE (mm), raw triangulation, rows = y from +1.25 (front) to -1.25 (back), cols = x -1.25..+1.25")
    for iy, y in enumerate(centres[::-1]):
        _say(f"  y={y:+.2f} | " + " ".join(f"{v:6.1f}" for v in table["raw"][iy]))
    _say("MPJPE (mm), with One-Euro smoothing")
    for iy, y in enumerate(centres[::-1]):
        _say(f"  y={y:+.2f} | " + " ".join(f"{v:6.1f}" for v in table["one_euro"][iy]))
    _say("valid joints (% of 17 per frame)")
    for iy, y in enumerate(centres[::-1]):
        _say(f"  y={y:+.2f} | " + " ".join(f"{100 * v:6.1f}" for v in valid_frac[iy]))
    summary = {}
    for name, mask in rings.items():
        summary[name] = {
            "raw_mm": float(np.nanmean(table["raw"][mask])),
            "one_euro_mm": float(np.nanmean(table["one_euro"][mask])),
            "valid_pct": 100 * float(np.nanmean(valid_frac[mask])),
        }
        _say(
            f"  {name:30s} raw {summary[name]['raw_mm']:6.1f} mm   "
            f"one-euro {summary[name]['one_euro_mm']:6.1f} mm   valid {summary[name]['valid_pct']:5.1f} %"
        )
    _say(f"  central 2 m x 2 m (all joints pooled): raw {centre_raw:.1f} mm, one-euro {centre_euro:.1f} mm")
    return {
        "grid_centres_m": centres.tolist(),
        "mpjpe_raw_mm": table["raw"].tolist(),
        "mpjpe_one_euro_mm": table["one_euro"].tolist(),
        "valid_fraction": valid_frac.tolist(),
        "central_2x2_raw_mm": centre_raw,
        "central_2x2_one_euro_mm": centre_euro,
        "by_region": summary,
    }


# ------------------------------------------------------------------------------------------ demo


def _detect_demo(cache: Path, input_long_side: int) -> dict[str, Any]:
    """Run the real pose model over the demo videos once; cached as NPZ."""
    import cv2

    from app.core.config import load_settings
    from pipeline.demo_data import fetch_demo
    from pipeline.pose.config import PoseConfig
    from pipeline.pose.detector import PoseDetector
    from pipeline.pose.prepare import prepare_pose_model

    settings = load_settings()
    demo = fetch_demo(settings.paths.cache_dir)
    out = cache / f"demo_detections_{input_long_side}.npz"
    if out.is_file():
        data = dict(np.load(out, allow_pickle=False))
        data["demo_root"] = str(demo.root)
        return data
    model = prepare_pose_model(settings.paths.models_dir).path
    det = PoseDetector.load(PoseConfig(input_long_side=input_long_side, parallel=1), model)
    names = sorted(demo.videos)
    caps = [cv2.VideoCapture(str(demo.videos[n])) for n in names]
    fps = caps[0].get(cv2.CAP_PROP_FPS) or 60.0
    rows: dict[str, list[Any]] = {k: [] for k in ("frame", "cam", "box", "bscore", "kp", "kscore")}
    sizes: list[tuple[int, int]] = [(0, 0)] * len(names)
    f = 0
    t0 = time.perf_counter()
    while True:
        imgs = []
        for cap in caps:
            ok, img = cap.read()
            if not ok:
                break
            imgs.append(img)
        if len(imgs) != len(caps):
            break
        batch = det.detect(imgs, names, f, f / fps)
        for ci, v in enumerate(batch.views):
            sizes[ci] = v.image_size
            for p in range(len(v)):
                rows["frame"].append(f)
                rows["cam"].append(ci)
                rows["box"].append(v.boxes_xyxy[p])
                rows["bscore"].append(v.box_scores[p])
                rows["kp"].append(v.keypoints_xy[p])
                rows["kscore"].append(v.keypoint_scores[p])
        f += 1
        if f % 20 == 0:
            _say(f"  pose model: {f} frames x {len(names)} views ({time.perf_counter() - t0:.0f} s)")
    data = {
        "frame": np.array(rows["frame"]),
        "cam": np.array(rows["cam"]),
        "box": np.array(rows["box"]),
        "bscore": np.array(rows["bscore"]),
        "kp": np.array(rows["kp"]),
        "kscore": np.array(rows["kscore"]),
        "names": np.array(names),
        "sizes": np.array(sizes),
        "fps": np.array(fps),
        "n_frames": np.array(f),
    }
    cache.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(out, **data)
    data["demo_root"] = str(demo.root)
    return data


def _anipose_group(cameras: list[Camera]) -> Any:
    from aniposelib.cameras import Camera as ACamera
    from aniposelib.cameras import CameraGroup

    return CameraGroup(
        [
            ACamera(name=c.name, size=c.image_size, matrix=c.K, dist=c.dist, rvec=c.rvec, tvec=c.t)
            for c in cameras
        ]
    )


def _leg_stats(joints: np.ndarray) -> dict[str, dict[str, float]]:
    out = {}
    for name, (a, b) in LEGS.items():
        lengths = np.linalg.norm(joints[:, J[a]] - joints[:, J[b]], axis=1)
        lengths = lengths[np.isfinite(lengths)]
        out[name] = {
            "mean_mm": 1000 * float(lengths.mean()),
            "std_mm": 1000 * float(lengths.std()),
            "frames": len(lengths),
        }
    return out


def bench_demo(cache: Path, input_long_side: int, min_score: float) -> dict[str, Any]:
    from pipeline.calibration.io import load_calibration
    from pipeline.demo_data import DemoData
    from pipeline.pose.types import ViewDetections
    from pipeline.tracking.ocsort import MultiViewTracker

    data = _detect_demo(cache, input_long_side)
    demo = DemoData(Path(data["demo_root"]))
    cams = load_calibration(demo.calibration)
    names = [str(n) for n in data["names"]]
    if [c.name for c in cams] != names:
        raise SystemExit(f"calibration cameras {[c.name for c in cams]} do not match videos {names}")
    n_frames, fps = int(data["n_frames"]), float(data["fps"])
    tracker = MultiViewTracker(names)
    rec = Reconstructor(
        cams,
        ReconstructionConfig(
            triangulation=RAW.triangulation.__class__(min_score=min_score), tracks=RAW.tracks
        ),
    )
    per_frame: list[tuple[int, np.ndarray, np.ndarray, Any]] = []  # frame, uv (4,17,2), scores (4,17), person
    for f in range(n_frames):
        views = []
        for ci, name in enumerate(names):
            sel = (data["frame"] == f) & (data["cam"] == ci)
            size = tuple(int(v) for v in data["sizes"][ci])
            views.append(
                ViewDetections(
                    name,
                    f,
                    f / fps,
                    size,
                    data["box"][sel],
                    data["bscore"][sel],  # type: ignore[arg-type]
                    data["kp"][sel],
                    data["kscore"][sel],
                )
            )
        tracked = tracker.update(views)
        people = rec.update(list(tracked), f / fps)
        for p in people:
            uv = np.full((len(names), 17, 2), np.nan)
            sc = np.zeros((len(names), 17))
            for cam, tid in p.views:
                tv = tracked[names.index(cam)]
                k = int(np.flatnonzero(tv.track_ids == tid)[0])
                uv[names.index(cam)] = tv.keypoints_xy[k]
                sc[names.index(cam)] = tv.keypoint_scores[k]
            per_frame.append((f, uv, sc, p))
    if not per_frame:
        raise SystemExit("no 3D person reconstructed on the demo")
    counts: dict[int, int] = {}
    for _, _, _, p in per_frame:
        counts[p.user_id] = counts.get(p.user_id, 0) + 1
    subject = max(counts, key=lambda u: counts[u])
    rows = [(f, uv, sc) for f, uv, sc, p in per_frame if p.user_id == subject]
    _say(
        f"\n== (b) Pose2Sim Demo_SinglePerson: {n_frames} frames x {len(names)} views, yolo11n-pose at "
        f"{input_long_side} px, users seen {counts} -> subject {subject} in {len(rows)} frames =="
    )
    uv_all = np.stack([r[1] for r in rows])  # (F, C, 17, 2)
    sc_all = np.stack([r[2] for r in rows])
    rig = CameraRig.from_cameras(cams)
    params = rec.config.triangulation
    confident = (sc_all >= min_score) & np.all(np.isfinite(uv_all), axis=3)
    # The person's size in each view (as the Reconstructor computes it): the outlier floor scales with it.
    size_all = np.stack([person_size_px(uv_all[i], confident[i]) for i in range(len(rows))])  # (F, C)
    scale_all = np.repeat(size_all[:, :, None], 17, axis=2)

    n_rows = len(rows)
    c_count = len(names)

    def run_ours() -> np.ndarray:
        return np.stack(
            [
                triangulate(rig, uv_all[i], sc_all[i], params, scale_px=scale_all[i]).points_m
                for i in range(n_rows)
            ]
        )

    def run_ours_batched() -> np.ndarray:
        uv_b = uv_all.transpose(1, 0, 2, 3).reshape(c_count, -1, 2)
        sc_b = sc_all.transpose(1, 0, 2).reshape(c_count, -1)
        sz_b = scale_all.transpose(1, 0, 2).reshape(c_count, -1)
        return triangulate(rig, uv_b, sc_b, params, scale_px=sz_b).points_m.reshape(n_rows, 17, 3)

    def timed(fn: Any, repeats: int = 7) -> tuple[np.ndarray, tuple[float, float]]:
        """(result, (best wall ms, mean CPU ms) per frame) over ``repeats`` runs. On a shared machine
        the best wall time is the cost (timeit's rule); CPU time counts every thread of this process
        (jax may use several, so its CPU time can exceed its wall time)."""
        out = fn()
        best = np.inf
        c0 = time.process_time()
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn()
            best = min(best, time.perf_counter() - t0)
        cpu = (time.process_time() - c0) / repeats
        return out, (1000 * best / n_rows, 1000 * cpu / n_rows)

    ours, ours_ms = timed(run_ours)
    ours_b, ours_b_ms = timed(run_ours_batched)
    if not np.allclose(ours, ours_b, equal_nan=True, atol=1e-9):
        raise SystemExit("batched and per-frame triangulation differ")
    results = {"ours": ours}
    timing = {"ours": (ours_ms, ours_b_ms)}
    # The same without the validity gate on the reprojection error (every joint with 2 views kept,
    # as aniposelib does), so the joint coverage matches.
    keep_all = dataclasses.replace(params, max_reproj_px=1e9)
    results["ours_keep_all"] = np.stack(
        [
            triangulate(rig, uv_all[i], sc_all[i], keep_all, scale_px=scale_all[i]).points_m
            for i in range(n_rows)
        ]
    )
    timing["ours_keep_all"] = (ours_ms, ours_b_ms)
    try:
        group = _anipose_group(cams)
        import jax  # noqa: F401  (aniposelib 0.8 triangulates with jax)
    except ImportError as exc:
        _say(f"  aniposelib not importable ({exc}); its column is skipped")
        group = None
    if group is not None:
        pts = np.where(confident[..., None], uv_all, np.nan)

        def run_anipose() -> np.ndarray:
            return np.stack(
                [group.triangulate(pts[i], undistort=True, progress=False) for i in range(n_rows)]
            )

        def run_anipose_batched() -> np.ndarray:
            flat = pts.transpose(1, 0, 2, 3).reshape(c_count, -1, 2)
            return np.asarray(group.triangulate(flat, undistort=True, progress=False)).reshape(n_rows, 17, 3)

        ap, ap_ms = timed(run_anipose)
        _, ap_b_ms = timed(run_anipose_batched)
        timing["aniposelib"] = (ap_ms, ap_b_ms)
        results["aniposelib"] = ap
    report: dict[str, Any] = {
        "subject_frames": len(rows),
        "frames": n_frames,
        "input_long_side": input_long_side,
    }
    _say(
        f"  {'method':12s} {'joints':>7s} {'reproj all':>11s} {'median':>7s} {'reproj used':>12s} "
        f"{'ms/frame wall/CPU':>18s} {'batched':>14s}   thigh L/R std (mm)   shin L/R std (mm)"
    )
    for name, joints in results.items():
        flat = joints.reshape(-1, 3)
        err = np.stack(
            [reprojection_error(rig, np.nan_to_num(joints[i]), uv_all[i]) for i in range(len(rows))]
        )
        ok = np.all(np.isfinite(joints), axis=2)  # (F, 17)
        mask = confident & ok[:, None, :]
        all_err = err[mask]
        if name.startswith("ours"):
            prm = params if name == "ours" else keep_all
            used = np.stack(
                [
                    triangulate(rig, uv_all[i], sc_all[i], prm, scale_px=scale_all[i]).used
                    for i in range(len(rows))
                ]
            )
            used_err = err[used & mask]
        else:
            used_err = all_err
        legs = _leg_stats(joints)
        report[name] = {
            "valid_joints_pct": 100 * float(ok.mean()),
            "reproj_px_mean_all_confident_views": float(all_err.mean()),
            "reproj_px_median_all_confident_views": float(np.median(all_err)),
            "reproj_px_mean_used_views": float(used_err.mean()),
            "ms_per_person_frame_wall": timing[name][0][0],
            "ms_per_person_frame_cpu": timing[name][0][1],
            "ms_per_person_frame_batched_wall": timing[name][1][0],
            "ms_per_person_frame_batched_cpu": timing[name][1][1],
            "legs": legs,
            "points": int(np.isfinite(flat).all(axis=1).sum()),
        }
        _say(
            f"  {name:12s} {100 * ok.mean():6.1f}% {all_err.mean():10.2f}px {np.median(all_err):6.2f}px "
            f"{used_err.mean():11.2f}px {timing[name][0][0]:8.3f} /{timing[name][0][1]:7.3f} "
            f"{timing[name][1][0]:6.3f} /{timing[name][1][1]:6.3f}   "
            f"{legs['l_thigh']['std_mm']:5.1f} / {legs['r_thigh']['std_mm']:5.1f}      "
            f"{legs['l_shin']['std_mm']:5.1f} / {legs['r_shin']['std_mm']:5.1f}"
        )
    if "aniposelib" in results:
        both = np.all(np.isfinite(results["ours"]), axis=2) & np.all(
            np.isfinite(results["aniposelib"]), axis=2
        )
        mask = confident & both[:, None, :]
        e_o = np.stack(
            [reprojection_error(rig, np.nan_to_num(results["ours"][i]), uv_all[i]) for i in range(len(rows))]
        )[mask]
        e_a = np.stack(
            [
                reprojection_error(rig, np.nan_to_num(results["aniposelib"][i]), uv_all[i])
                for i in range(len(rows))
            ]
        )[mask]
        report["same_joints"] = {
            "ours_px": float(e_o.mean()),
            "aniposelib_px": float(e_a.mean()),
            "ours_median_px": float(np.median(e_o)),
            "aniposelib_median_px": float(np.median(e_a)),
        }
        _say(
            f"  on the joints both triangulate, all confident views: ours {e_o.mean():.2f} px "
            f"(median {np.median(e_o):.2f}), aniposelib {e_a.mean():.2f} px (median {np.median(e_a):.2f})"
        )
    return report


# ------------------------------------------------------------------------------------------ speed


def bench_speed(repeats: int) -> dict[str, Any]:
    from pipeline.camera import intrinsics, look_at, project
    from pipeline.pose.types import ViewDetections

    cams = []
    for i, (sx, sy) in enumerate([(1, 1), (-1, 1), (-1, -1), (1, -1)]):
        R, t = look_at(np.array([1.4 * sx, 1.4 * sy, 2.3]), np.array([0.0, 0.0, 1.0]))
        cams.append(
            Camera(
                f"cam0{i + 1}",
                (1920, 1080),
                intrinsics(1060, 1060, 960, 540),
                np.array([0.04, -0.06, 0.0005, -0.0003, 0.02]),
                R,
                t,
            )
        )
    rig = CameraRig.from_cameras(cams)
    rng = np.random.default_rng(0)
    base = np.array(
        [
            [0, 0.09, 1.62],
            [-0.03, 0.07, 1.66],
            [0.03, 0.07, 1.66],
            [-0.07, 0, 1.64],
            [0.07, 0, 1.64],
            [-0.19, 0, 1.42],
            [0.19, 0, 1.42],
            [-0.23, 0.02, 1.13],
            [0.23, 0.02, 1.13],
            [-0.25, 0.08, 0.88],
            [0.25, 0.08, 0.88],
            [-0.1, 0, 0.95],
            [0.1, 0, 0.95],
            [-0.11, 0.03, 0.51],
            [0.11, 0.03, 0.51],
            [-0.11, 0, 0.08],
            [0.11, 0, 0.08],
        ]
    )
    frames = []
    for _ in range(50):
        x = base + np.array([rng.uniform(-1, 1), rng.uniform(-1, 1), 0.0])
        uv = np.stack([project(c, x) for c in cams]) + rng.normal(0, 2.0, (4, 17, 2))
        bad = rng.random((4, 17)) < 0.05
        uv[bad] += rng.normal(0, 60.0, (int(bad.sum()), 2))  # 5 % outlier keypoints
        sc = rng.uniform(0.4, 1.0, (4, 17))
        size = np.repeat(person_size_px(uv, sc >= 0.3)[:, None], 17, axis=1)  # as the Reconstructor does
        frames.append((uv, sc, size))
    for uv, sc, size in frames[:5]:
        triangulate(rig, uv, sc, scale_px=size)
    # Mean CPU time over all passes, and the best pass's wall time (timeit's rule: on a shared
    # machine the minimum is the cost; the mean wall time mostly measures the other processes).
    best = np.inf
    c0 = time.process_time()
    for _ in range(repeats):
        t0 = time.perf_counter()
        for uv, sc, size in frames:
            triangulate(rig, uv, sc, scale_px=size)
        best = min(best, time.perf_counter() - t0)
    tri_ms = 1000 * best / len(frames)
    tri_cpu_ms = 1000 * (time.process_time() - c0) / (repeats * len(frames))

    def scene(n: int, f: int) -> list[TrackedView]:
        offsets = [(-0.7, -0.6), (0.7, 0.6), (0.7, -0.7), (-0.7, 0.7)][:n]
        views = []
        for c in cams:
            kps = np.stack([project(c, base + np.array([ox, oy, 0.0])) for ox, oy in offsets])
            kps = kps + rng.normal(0, 2.0, kps.shape)
            det = ViewDetections(
                c.name,
                f,
                f / 30,
                (1920, 1080),
                np.zeros((n, 4), np.float32),
                np.ones(n, np.float32),
                kps.astype(np.float32),
                np.full((n, 17), 0.9, np.float32),
            )
            views.append(TrackedView(det, np.arange(1, n + 1), np.arange(n)))
        return views

    update_ms: dict[int, tuple[float, float]] = {}
    for n in (1, 4):
        rec = Reconstructor(cams, SMOOTH)
        seq = [scene(n, f) for f in range(60)]
        for f in range(10):
            rec.update(seq[f], f / 30)
        passes = max(1, repeats // 4)
        best = np.inf
        c0 = time.process_time()
        for _ in range(passes):
            rec.reset()
            t0 = time.perf_counter()
            for f in range(10, 60):
                rec.update(seq[f], f / 30)
            best = min(best, time.perf_counter() - t0)
        update_ms[n] = (1000 * best / 50, 1000 * (time.process_time() - c0) / (50 * passes))
    _say("\n== (c) speed (this machine; best-pass wall clock, mean CPU time of this process) ==")
    _say(
        f"  triangulate(): 17 joints x 4 views, with undistortion, 5 % outlier keypoints: "
        f"{tri_ms:.3f} ms wall, {tri_cpu_ms:.3f} ms CPU per person-frame"
    )
    for n, (ms, cpu) in update_ms.items():
        _say(
            f"  Reconstructor.update(): {n} people x 4 views "
            "(association + triangulation + tracks + One-Euro): "
            f"{ms:.3f} ms wall, {cpu:.3f} ms CPU per frame ({cpu / n:.3f} ms CPU per person)"
        )
    return {
        "triangulate_ms_per_person_frame": tri_ms,
        "triangulate_cpu_ms_per_person_frame": tri_cpu_ms,
        "reconstructor_ms_per_frame": {str(k): v[0] for k, v in update_ms.items()},
        "reconstructor_cpu_ms_per_frame": {str(k): v[1] for k, v in update_ms.items()},
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--section", choices=("sim", "demo", "speed", "all"), default="all")
    ap.add_argument("--sim-seconds", type=float, default=2.0, help="seconds simulated per floor cell")
    ap.add_argument("--input-long-side", type=int, default=640, help="pose model input (long side, px)")
    ap.add_argument("--min-score", type=float, default=0.3, help="2D keypoint score threshold")
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cache", type=Path, default=Path.home() / ".cache" / "cavewalk" / "bench")
    ap.add_argument("--json", type=Path, help="also write the figures as JSON here")
    args = ap.parse_args()
    logging.basicConfig(level=logging.WARNING)
    out: dict[str, Any] = {}
    if args.section in ("speed", "all"):
        out["speed"] = bench_speed(args.repeats)
    if args.section in ("sim", "all"):
        out["sim"] = bench_sim(args.sim_seconds, args.seed)
    if args.section in ("demo", "all"):
        out["demo"] = bench_demo(args.cache, args.input_long_side, args.min_score)
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
