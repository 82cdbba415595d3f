"""Accuracy of the head pose (issue 20 item 3) on the simulator against its ground truth.

  .venv/bin/python scripts/eval_head.py [--seconds 60] [--seeds 3] [--latency-ms 0 50 100]
                                        [--bench BENCH.json] [--json OUT]

Each seed is a simulated CAVE (four ``kinect_color`` cameras, the navigator's random routines and
one bystander, the simulator's 2D faults) run through the live chain's own stages: OC-SORT per
view, the Reconstructor (association, triangulation, 3D tracks with their One-Euro smoothing) and
the head stage's HeadTracker. The ground truth is the head frame of the simulator's noise-free
joints: its face keypoints sit exactly on the head's rigid frame (pipeline/sim/body.py
FACE_OFFSETS_M: ears on the x axis, eyes on the y axis), so the same template fit on them is
exact (residual below 0.1 mm; the simulator's 0.3 s cross-fades between motion chunks bend the
face by up to a few millimetres: the script counts those person-frames and stops above 5 mm).

A pose computed from the frames captured at t reaches the wall at t + L (L the pipeline's
latency); it is compared with the true head at t + L (interpolated between simulator frames:
positions linearly, rotations by slerp), once as measured (no prediction) and once predicted
L ahead as the emitter does (``HeadConfig.horizon_s``: at most ``max_horizon_ms``). Errors:
position (mm, the point between the eyes), rotation (deg, the angle of the
relative rotation) and forward direction (deg); p50 and p95 over every person-frame matched to a
simulated person within 0.4 m: the navigator's (``--everyone``: the bystander's as well, who
roams up to the walls where fewer cameras see the face). ``--bench`` adds the end-to-end p50
of a ``cavewalk bench --json`` file to the latencies.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation, Slerp

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pipeline.cave import box_cave  # noqa: E402
from pipeline.head.config import HeadConfig  # noqa: E402
from pipeline.head.pose import angle_deg, direction_angle_deg, head_pose_from_joints  # noqa: E402
from pipeline.head.tracker import HeadTracker  # noqa: E402
from pipeline.sim.world import SimConfig, SimWorld  # noqa: E402
from pipeline.tracking.ocsort import MultiViewTracker  # noqa: E402
from pipeline.triangulation.reconstructor import Reconstructor  # noqa: E402

MATCH_M = 0.4


def simulate(seed: int, seconds: float, fps: float) -> dict[str, Any]:
    """One simulated run through tracking and triangulation: the people of every frame, the true
    head poses, and which user matches which simulated person."""
    world = SimWorld.build(box_cave(), SimConfig(fps=fps, bystanders=1, seed=seed))
    tracker = MultiViewTracker([c.name for c in world.cameras])
    rec = Reconstructor(world.cameras)
    n = int(seconds * fps)
    truth_p = np.full((n, len(world.people), 3), np.nan)
    truth_r = np.full((n, len(world.people), 3, 3), np.nan)
    frames: list[tuple[float, list[Any], dict[int, int]]] = []
    bent = 0  # true heads off the rigid template by > 0.1 mm (the cross-fades between motion chunks)
    for k in range(n):
        frame = world.step()
        for i, (_, joints) in enumerate(frame.truth):
            hf = head_pose_from_joints(joints, scale=None)
            if hf is None or hf.residual_m > 5e-3:
                raise RuntimeError(
                    f"ground truth head of person {i} at frame {k} does not fit the "
                    f"template ({None if hf is None else hf.residual_m})"
                )
            bent += hf.residual_m > 1e-4
            truth_p[k, i], truth_r[k, i] = hf.position_m, hf.rotation
        people = rec.update(tracker.update(frame.views), frame.timestamp_s)
        match: dict[int, int] = {}
        for person in people:
            d = [np.linalg.norm(person.position_m[:2] - j[[11, 12]].mean(axis=0)[:2]) for _, j in frame.truth]
            i = int(np.argmin(d))
            if d[i] <= MATCH_M:
                match[person.user_id] = i
        frames.append((frame.timestamp_s, people, match))
    return {"fps": fps, "frames": frames, "truth_p": truth_p, "truth_r": truth_r, "bent": int(bent)}


def score(
    sim: dict[str, Any], latencies_s: list[float], config: HeadConfig, everyone: bool = False
) -> dict[str, dict[str, list[float]]]:
    """Errors of the head stage on a simulated run, for each latency, measured and predicted."""
    fps, truth_p, truth_r = sim["fps"], sim["truth_p"], sim["truth_r"]
    n = truth_p.shape[0]
    heads = HeadTracker(config)
    estimates: list[tuple[int, int, Any]] = []  # (frame, person index, HeadEstimate)
    for k, (t, people, match) in enumerate(sim["frames"]):
        for est in heads.update(people, t):
            i = match.get(est.user_id)
            if i is not None and (everyone or i == 0):
                estimates.append((k, i, est))
    times = np.arange(n) / fps
    slerps = [Slerp(times, Rotation.from_matrix(truth_r[:, i])) for i in range(truth_r.shape[1])]
    out: dict[str, dict[str, list[float]]] = {}
    for lat in latencies_s:
        for mode in ("measured", "predicted"):
            errs: dict[str, list[float]] = {"position_mm": [], "rotation_deg": [], "forward_deg": []}
            for k, i, est in estimates:
                t_show = times[k] + lat
                if t_show > times[-1]:
                    continue
                j = min(int(t_show * fps), n - 2)
                a = (t_show - times[j]) * fps
                p_true = (1 - a) * truth_p[j, i] + a * truth_p[j + 1, i]
                r_true = slerps[i](t_show).as_matrix()
                pose = est.predict(config.horizon_s(lat) if mode == "predicted" else 0.0)
                r_est = np.stack([np.cross(pose.forward, pose.up), pose.forward, pose.up], axis=1)
                errs["position_mm"].append(1000 * float(np.linalg.norm(np.asarray(pose.position_m) - p_true)))
                errs["rotation_deg"].append(angle_deg(r_est, r_true))
                errs["forward_deg"].append(direction_angle_deg(np.asarray(pose.forward), r_true[:, 1]))
            out[f"{round(lat * 1000)}ms/{mode}"] = errs
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--fps", type=float, default=30.0)
    ap.add_argument("--latency-ms", type=float, nargs="*", default=[0.0, 50.0, 100.0])
    ap.add_argument("--bench", type=Path, help="a `cavewalk bench --json` file: its sim end-to-end p50 too")
    ap.add_argument(
        "--everyone",
        action="store_true",
        help="score the bystander too (default: the navigator, who stands near the centre)",
    )
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    lats = list(args.latency_ms)
    bench_note = None
    if args.bench is not None:
        data = json.loads(args.bench.read_text())
        scen = data.get("scenarios", data)
        for name, figures in scen.items():
            if isinstance(figures, dict) and "latency_ms" in figures and "sim" in name:
                p50 = figures["latency_ms"]["end_to_end"]["p50"]
                lats.append(float(p50))
                bench_note = f"{name}: end-to-end p50 {p50} ms"
    config = HeadConfig()
    pooled: dict[str, dict[str, list[float]]] = {}
    bent = 0
    for seed in range(args.seeds):
        sim = simulate(seed, args.seconds, args.fps)
        bent += sim["bent"]
        res = score(sim, [v / 1000 for v in lats], config, args.everyone)
        for key, errs in res.items():
            for m, vals in errs.items():
                pooled.setdefault(key, {}).setdefault(m, []).extend(vals)
    table: dict[str, Any] = {}
    print(f"{'latency/mode':22s} {'n':>6s}  position mm p50/p95   rotation deg p50/p95   forward deg p50/p95")
    for key, errs in pooled.items():
        row = {
            m: {"p50": round(float(np.percentile(v, 50)), 2), "p95": round(float(np.percentile(v, 95)), 2)}
            for m, v in errs.items()
            if v
        }
        row["n"] = len(errs["position_mm"])
        table[key] = row
        print(
            f"{key:22s} {row['n']:6d}  {row['position_mm']['p50']:8.1f} / {row['position_mm']['p95']:6.1f}"
            f"      {row['rotation_deg']['p50']:6.2f} / {row['rotation_deg']['p95']:6.2f}"
            f"        {row['forward_deg']['p50']:6.2f} / {row['forward_deg']['p95']:6.2f}"
        )
    report = {
        "table": table,
        "everyone": args.everyone,
        "seconds": args.seconds,
        "seeds": args.seeds,
        "fps": args.fps,
        "bench": bench_note,
        "truth_bent_person_frames": bent,
        "config": {k: getattr(config, k) for k in config.__slots__},
        "machine": {
            "cpu": platform.processor() or platform.machine(),
            "cpus": os.cpu_count(),
            "load_avg": [round(v, 2) for v in os.getloadavg()],
        },
    }
    if args.json:
        args.json.write_text(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
