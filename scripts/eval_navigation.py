"""Per-person accuracy of the navigation modes (issue 20 item 1) on the simulator.

  .venv/bin/python scripts/eval_navigation.py [--seeds 3 4 5 6] [--modes single each group]
                                              [--cost 1 2 4] [--json OUT]

Each seed is a simulated CAVE (four ``kinect_color`` cameras, the simulator's 2D faults, no
bystanders) with three people stepping scripted routines side by side, run through the live
chain's own fusion stage (OC-SORT, the Reconstructor, the navigator choice, the recogniser and
the navigation stage). The routines: 1 s still, then phase A (forward / left / right: the room
disagrees) and phase B (forward / forward / still: a majority forward), 3.5 s each, then still.
Each person's own command (``NavigationFrame.commands``, matched to the nearest simulated person)
is scored against their true action, except for 1 s after each change of action (the
recogniser's onset) and 0.5 s before one (the stepping winds down). In group mode the room's
command is scored against the rule's answer on the true actions (still in A, forward in B).
The same set-up as tests/pipeline/navigation/test_modes.py, over several seeds.

``--cost N ...``: the CPU time of the fusion stage per frame (``time.process_time`` around
``Fusion.update`` only, so the simulator's own work and other processes' load are left out; a
loaded machine still inflates it a little through shared caches) with N stepping people on their
random routines, in single and each mode: what each extra navigator costs.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pipeline.cave import box_cave  # noqa: E402
from pipeline.navigation.config import NavigationConfig  # noqa: E402
from pipeline.runtime.messages import DetectedFrame  # noqa: E402
from pipeline.runtime.stages import FusionFactory  # noqa: E402
from pipeline.sim.scene import default_cameras  # noqa: E402
from pipeline.sim.script import MotionScript, Segment  # noqa: E402
from pipeline.sim.world import SimConfig, SimWorld  # noqa: E402

FPS = 30.0
LEAD_S, PHASE_S, ONSET_S, WIND_DOWN_S = 1.0, 3.5, 1.0, 0.5
PEOPLE = (  # (start xy, phase A, phase B)
    ((-0.8, -0.5), "forward", "forward"),
    ((0.8, -0.5), "left", "forward"),
    ((0.0, 0.8), "right", "still"),
)
GROUP_TRUTH = ("still", "forward")


def run(mode: str, seed: int) -> dict[str, Any]:
    scripts = [MotionScript((Segment("still", LEAD_S), Segment(a, PHASE_S), Segment(b, PHASE_S),
                             Segment("still", 1.0)), start_xy_m=xy, start_yaw_deg=0.0) for xy, a, b in PEOPLE]
    cave = box_cave()
    world = SimWorld(cave, default_cameras(cave, "kinect_color", 4),
                     SimConfig(fps=FPS, bystanders=0, seed=seed), scripts[0], steppers=scripts[1:])
    fusion = FusionFactory(cameras=tuple(world.cameras), camera_names=tuple(c.name for c in world.cameras),
                           navigation=NavigationConfig(mode))()  # type: ignore[arg-type]
    hits = [0, 0, 0]
    scored = [0, 0, 0]
    group = [0, 0]
    window = 0
    t0 = time.process_time()
    frames = round((LEAD_S + 2 * PHASE_S) * FPS)
    for _ in range(frames):
        f = world.step()
        t = f.timestamp_s
        nav = fusion.update(DetectedFrame(f.frame_index, t, f.views, t, t)).navigation
        phase = 0 if t < LEAD_S + PHASE_S else 1
        since = t - (LEAD_S + phase * PHASE_S)
        if since < ONSET_S or since > PHASE_S - WIND_DOWN_S or nav is None:
            continue
        window += 1
        truth_xy = [j[[11, 12], :2].mean(axis=0) for _, j in f.truth]
        for c in nav.commands:
            k = int(np.argmin([np.linalg.norm(np.asarray(c.position_m[:2]) - xy) for xy in truth_xy]))
            scored[k] += 1
            hits[k] += c.action.label == f.labels[k]
        if mode == "group":
            group[1] += 1
            group[0] += nav.group is not None and nav.group.action.label == GROUP_TRUTH[phase]
    return {
        "mode": mode, "seed": seed, "window_frames": window,
        "per_person": [{"person": k, "actions": [a, b], "scored_frames": scored[k],
                        "accuracy": round(hits[k] / scored[k], 4) if scored[k] else None}
                       for k, (_, a, b) in enumerate(PEOPLE)],
        "group_accuracy": round(group[0] / group[1], 4) if group[1] else None,
        "cpu_s_per_frame": round((time.process_time() - t0) / frames, 5),
    }


def cost(people: int, mode: str, frames: int = 240, seed: int = 7) -> dict[str, Any]:
    cave = box_cave()
    world = SimWorld(cave, default_cameras(cave, "kinect_color", 4),
                     SimConfig(fps=FPS, bystanders=0, seed=seed, people=people))
    fusion = FusionFactory(cameras=tuple(world.cameras), camera_names=tuple(c.name for c in world.cameras),
                           navigation=NavigationConfig(mode))()  # type: ignore[arg-type]
    spent: list[float] = []
    navigators: list[int] = []
    for i in range(frames):
        f = world.step()
        t = f.timestamp_s
        frame = DetectedFrame(f.frame_index, t, f.views, t, t)
        c0 = time.process_time()
        nav = fusion.update(frame).navigation
        if i >= 30:  # the first second: tracks and recogniser states start
            spent.append(time.process_time() - c0)
            navigators.append(len(nav.commands) if nav is not None else 0)
    arr = 1000.0 * np.asarray(spent)
    return {"people": people, "mode": mode, "frames": len(spent),
            "fusion_cpu_ms_mean": round(float(arr.mean()), 3),
            "fusion_cpu_ms_p50": round(float(np.median(arr)), 3),
            "navigators_mean": round(float(np.mean(navigators)), 2)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[3, 4, 5, 6])
    modes = ["single", "each", "group"]
    ap.add_argument("--modes", nargs="*", default=modes, choices=modes)
    ap.add_argument("--cost", type=int, nargs="*", default=[], help="people counts (1-4) for the CPU cost")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    load = [round(v, 2) for v in os.getloadavg()]
    costs = [cost(n, m) for n in args.cost for m in ("single", "each")]
    runs = [run(m, s) for m in args.modes for s in args.seeds]
    print(f"load {load} at the start, {[round(v, 2) for v in os.getloadavg()]} at the end")
    for m in args.modes:
        rs = [r for r in runs if r["mode"] == m]
        for k, (_, a, b) in enumerate(PEOPLE):
            accs = [r["per_person"][k]["accuracy"] for r in rs]
            frames = [r["per_person"][k]["scored_frames"] for r in rs]
            if not any(frames):
                print(f"{m:<6} person {k} ({a}/{b}): not a navigator")
                continue
            shown = " ".join("  -  " if x is None else f"{x:.2f}" for x in accs)
            print(f"{m:<6} person {k} ({a}/{b}): accuracy per seed {shown}; "
                  f"scored {sum(frames)} of {sum(r['window_frames'] for r in rs)} frames")
        if m == "group":
            print("group  the room (still / forward): per seed "
                  + " ".join(f"{r['group_accuracy']:.2f}" for r in rs))
        cpu_ms = 1000 * np.mean([r["cpu_s_per_frame"] for r in rs])
        print(f"{m:<6} simulator + fusion CPU per frame {cpu_ms:.1f} "
              "ms (process time of this process; --cost times the fusion stage alone)")
    for c in costs:
        print(f"cost   {c['people']} people, {c['mode']:<6}: fusion CPU {c['fusion_cpu_ms_mean']:.2f} "
              f"ms/frame (p50 {c['fusion_cpu_ms_p50']:.2f}), {c['navigators_mean']:.2f} navigators")
    if args.json:
        args.json.write_text(json.dumps({"load_avg": load, "seeds": args.seeds, "runs": runs, "costs": costs},
                                        indent=1))
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
