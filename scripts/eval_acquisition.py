#!/usr/bin/env python
"""Does finding a standing person move them? Simulated acquisitions: a person of random height and
facing stands still for 3 s, seen through the simulated CAVE cameras and our triangulation (the
training data's capture faults: pixel noise, drift, dropped joints, 1 % outliers), streamed from
its first frame through the committed model and gate with the default settings (the recogniser
starts from nothing, as after a new navigator or a long gap).

    .venv/bin/python scripts/eval_acquisition.py [--sequences 300] [--seed 1000] [--json OUT]

Prints how many acquisitions called any frame moving, how many did so within the first 0.7 s
(while the tracker and the network are still warming up), and the moving frames in all. Seeds
``seed .. seed + sequences - 1``; none of these routines is in the training data.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pipeline.recognition.recognizer import ActionRecognizer, RecognizerConfig, recognize_sequence  # noqa: E402
from pipeline.recognition.train import NoiseConfig, capture  # noqa: E402
from pipeline.sim.body import body_from_height  # noqa: E402
from pipeline.sim.motion import simulate_user  # noqa: E402
from pipeline.sim.script import MotionScript, Segment  # noqa: E402

FPS = 30.0
STAND_S = 3.0  # each acquisition: this long standing
WARM_S = 0.7


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sequences", type=int, default=300)
    ap.add_argument("--seed", type=int, default=1000)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    if args.sequences < 1:
        print("error: --sequences must be at least 1", file=sys.stderr)
        return 2
    if args.seed < 0:
        print(f"error: --seed must be >= 0, got {args.seed}", file=sys.stderr)
        return 2
    if args.json is not None and not args.json.parent.is_dir():
        print(f"error: --json {args.json}: no folder {args.json.parent} to write it in", file=sys.stderr)
        return 2
    recognizer = ActionRecognizer.from_config(RecognizerConfig())
    moving = early = frames = total = 0
    for n in range(args.sequences):
        seed = args.seed + n
        rng = np.random.default_rng(seed)
        script = MotionScript(
            (Segment("still", STAND_S, gestures=()),),
            start_xy_m=(0.2, -0.1),
            start_yaw_deg=float(rng.uniform(-90.0, 90.0)),
        )
        motion = simulate_user(script, body_from_height(float(rng.uniform(1.5, 1.95))), FPS, seed=seed)
        joints = capture(motion.joints_m, np.random.default_rng(seed), NoiseConfig(), FPS)
        labels = [e.label for e in recognize_sequence(recognizer, joints, FPS)]
        called = [i for i, lab in enumerate(labels) if lab != "still"]
        moving += bool(called)
        early += bool(called) and called[0] < WARM_S * FPS
        frames += len(called)
        total += len(labels)
    result = {
        "sequences": args.sequences,
        "seed": args.seed,
        "moving_sequences": moving,
        "moving_within_warmup": early,
        "warmup_s": WARM_S,
        "moving_frames": frames,
        "frames": total,
    }
    last = args.seed + args.sequences - 1
    print(
        f"standing acquisitions: {args.sequences} x {STAND_S:g} s (seeds {args.seed}..{last}): "
        f"{moving} called moving, {early} within the first {WARM_S} s, {frames} moving frames of {total}"
    )
    if args.json is not None:
        args.json.write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
