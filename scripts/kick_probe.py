"""Write labelled SPEC skeletons of a person standing who kicks now and then, for `cavewalk evaluate`.

    .venv/bin/python scripts/kick_probe.py --pose ~/.cache/cavewalk/data/sources/still-heldout/X.npz --out DIR

A probe, not a motion model: the first frame of ``--pose`` (a standing person) held for 20 s with a
slow 1 cm sway, and four kicks (right front, left front, right to the side, left front; 0.9 s
each, the leg swung straight about the hip up to ``--raise`` degrees, the knee bent on the way up
and down), 1.2 cm of noise per joint. Every frame is labelled ``still``; the kicks are tagged
``kick``, the rest untagged, so `cavewalk evaluate` reports false movement during the kicks and in
the standing after them. One file per ``--seeds`` value (different noise).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pipeline.skeleton import J  # noqa: E402

FPS = 30.0
KICKS = ((3.0, 1, "front"), (7.0, 0, "front"), (11.0, 1, "side"), (15.0, 0, "front"))  # t0, leg, kind


def probe(pose: np.ndarray, raise_deg: float, seed: int) -> dict[str, Any]:
    n = int(20 * FPS)
    t = np.arange(n) / FPS
    joints = np.repeat(pose[None].astype(np.float64), n, axis=0)
    joints[:, :, 0] += 0.01 * np.sin(2 * np.pi * 0.3 * t)[:, None]
    tags = np.full(n, "", dtype=object)
    contacts = np.ones((n, 2), dtype=bool)
    up = np.array([0.0, 0.0, 1.0])
    for t0, leg, kind in KICKS:
        hip_i, knee_i, ankle_i = (J["l_hip"], J["l_knee"], J["l_ankle"]) if leg == 0 else (
            J["r_hip"], J["r_knee"], J["r_ankle"])  # fmt: skip
        a, b = int(t0 * FPS), int((t0 + 0.9) * FPS)
        for i in range(a, b):
            s = (i - a) / (b - a)
            hip, knee, ankle = joints[i, hip_i], joints[i, knee_i], joints[i, ankle_i]
            thigh, shank = np.linalg.norm(knee - hip), np.linalg.norm(ankle - knee)
            right = joints[i, J["r_hip"]] - joints[i, J["l_hip"]]
            right[2] = 0.0
            right /= np.linalg.norm(right)
            out = np.cross(up, right) if kind == "front" else (right if leg == 1 else -right)
            th = np.radians(raise_deg) * np.sin(np.pi * s)  # the thigh's raise
            bend = np.radians(100.0) * np.sin(np.pi * s) * (1 - 0.95 * np.exp(-(((s - 0.5) / 0.12) ** 2)))
            knee = hip + thigh * (-up * np.cos(th) + out * np.sin(th))
            joints[i, knee_i] = knee
            joints[i, ankle_i] = knee + shank * (-up * np.cos(th - bend) + out * np.sin(th - bend))
            tags[i] = "kick"
            contacts[i, leg] = False
    joints += np.random.default_rng(seed).normal(0.0, 0.012, joints.shape)
    return {
        "joints": joints.astype(np.float32),
        "fps": np.float32(FPS),
        "labels": np.array(["still"] * n),
        "tags": tags.astype(str),
        "contacts": contacts,
        "source": np.array("kick-probe"),
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pose", type=Path, required=True, help="a SPEC NPZ, its first frame a person standing")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--raise", dest="raise_deg", type=float, default=80.0, help="the thighs' raise (deg)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    args = ap.parse_args()
    if not 0.0 < args.raise_deg <= 120.0:  # NaN fails too
        print(f"error: --raise must be in (0, 120] degrees, got {args.raise_deg}", file=sys.stderr)
        return 2
    try:
        pose = np.load(args.pose)["joints"][0]
    except (OSError, KeyError, IndexError, ValueError) as exc:
        print(f"error: {args.pose}: not a SPEC skeleton file ({exc})", file=sys.stderr)
        return 2
    if pose.shape != (len(J), 3) or not np.isfinite(pose).all():
        print(f"error: {args.pose}: its first frame is not a whole skeleton ({pose.shape})", file=sys.stderr)
        return 2
    try:
        args.out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        print(f"error: --out {args.out}: cannot be a folder ({exc})", file=sys.stderr)
        return 2
    for seed in args.seeds:
        path = args.out / f"kick_probe_{seed}.npz"
        np.savez(path, **probe(pose, args.raise_deg, seed))
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
