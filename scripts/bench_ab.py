#!/usr/bin/env python
"""Paired speed comparison of the streaming recogniser in two checkouts: this one and ``--baseline``.

    .venv/bin/python scripts/bench_ab.py --baseline ../cavewalk-old [--frames 1800] [--chunk 30]
        [--passes 3] [--json out.json]

On a shared machine the time of one ``scripts/bench_recognition.py`` run swings up to 2x from one run
to the next, so two runs compare code changes of 10 % poorly. Here each checkout runs in a process of
its own (its own ``pipeline`` package and its own ``pipeline/recognition/action.onnx``), both over the
same frames (a simulated routine with capture noise), and they take turns: ``--chunk`` frames in one,
the same frames in the other, the first to go alternating, so both see the same phases of the host.
Each ``update()`` is timed inside its process. Reported: each side's median per frame and the median
of the per-frame ratios (this checkout / the baseline), with the machine
(:func:`pipeline.machine.machine_facts`). The baseline needs only ``ActionRecognizer``,
``RecognizerConfig`` and ``open_session``, so any checkout since the recogniser has had them works,
e.g. a ``git worktree add`` of an older commit.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import IO, Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bench_recognition import routine  # noqa: E402

from pipeline.machine import machine_facts  # noqa: E402

MODEL = Path("pipeline") / "recognition" / "action.onnx"

# Runs in each checkout: sys.argv = [checkout, frames.npy, fps]; then one command per line on stdin,
# "run A B" (times update() over frames A..B-1, answers their times in seconds as one JSON line),
# "reset" or "quit".
_WORKER = """
import json, sys, time
from pathlib import Path
root, frames, fps = Path(sys.argv[1]), sys.argv[2], float(sys.argv[3])
sys.path.insert(0, str(root))
import numpy as np
from pipeline.recognition.recognizer import ActionRecognizer, RecognizerConfig, open_session
joints = np.load(frames)
model = root / "pipeline" / "recognition" / "action.onnx"
rec = ActionRecognizer(open_session(model, 1), RecognizerConfig(model_path=model, threads=1))
for i in range(min(100, len(joints))):
    rec.update(joints[i], i / fps)
rec.reset()
print("ready", flush=True)
for line in sys.stdin:
    cmd = line.split()
    if cmd[0] == "quit":
        break
    if cmd[0] == "reset":
        rec.reset()
        print("ok", flush=True)
        continue
    a, b = int(cmd[1]), int(cmd[2])
    times = []
    for i in range(a, b):
        t0 = time.perf_counter()
        rec.update(joints[i], i / fps)
        times.append(time.perf_counter() - t0)
    print(json.dumps(times), flush=True)
"""


class _Worker:
    """One checkout's recogniser in a process of its own."""

    def __init__(self, checkout: Path, frames: Path, fps: float) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-c", _WORKER, str(checkout), str(frames), str(fps)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            cwd=checkout,
        )
        if self._line() != "ready":
            raise RuntimeError(f"the recogniser of {checkout} did not start")

    def _line(self) -> str:
        out: IO[str] | None = self.proc.stdout
        assert out is not None
        line = out.readline()
        if not line:
            raise RuntimeError(f"a worker ended (exit code {self.proc.wait()})")
        return line.strip()

    def ask(self, command: str) -> str:
        assert self.proc.stdin is not None
        self.proc.stdin.write(command + "\n")
        self.proc.stdin.flush()
        return self._line()

    def close(self) -> None:
        if self.proc.poll() is None:
            assert self.proc.stdin is not None
            self.proc.stdin.write("quit\n")
            self.proc.stdin.close()
            self.proc.wait(timeout=30)


def compare(baseline: Path, frames: int, chunk: int, passes: int) -> dict[str, Any]:
    """Per-frame ``update()`` times (ms) of this checkout and ``baseline``, taking turns by chunks."""
    fps = 30.0
    joints = routine(frames, fps)[:frames]  # scripts/bench_recognition.py's routine
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "frames.npy"
        np.save(path, joints)
        workers = [_Worker(ROOT, path, fps), _Worker(baseline, path, fps)]
        try:
            times = np.zeros((2, len(joints)))
            for p in range(passes):
                for w in workers:
                    w.ask("reset")
                for k, a in enumerate(range(0, len(joints), chunk)):
                    b = min(a + chunk, len(joints))
                    for side in (0, 1) if (k + p) % 2 == 0 else (1, 0):
                        times[side, a:b] += json.loads(workers[side].ask(f"run {a} {b}"))
        finally:
            for w in workers:
                w.close()
    ms = times / passes * 1000.0
    ratio = ms[0] / ms[1]
    machine = machine_facts()
    return {
        "this_ms": {"median": float(np.median(ms[0])), "p95": float(np.percentile(ms[0], 95))},
        "baseline_ms": {"median": float(np.median(ms[1])), "p95": float(np.percentile(ms[1], 95))},
        "ratio_of_medians": float(np.median(ms[0]) / np.median(ms[1])),
        "per_frame_ratio": {
            q: float(np.percentile(ratio, p)) for q, p in (("p25", 25), ("median", 50), ("p75", 75))
        },
        "frames": len(joints),
        "chunk": chunk,
        "passes": passes,
        "this": str(ROOT),
        "baseline": str(baseline),
        "cpu": machine.summary(),
        "machine": machine.as_dict(),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--baseline", type=Path, required=True, help="another checkout of cavewalk")
    ap.add_argument("--frames", type=int, default=1800)
    ap.add_argument("--chunk", type=int, default=30, help="frames per turn")
    ap.add_argument("--passes", type=int, default=3, help="times over the frames (medians of the sums)")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    if min(args.frames, args.chunk, args.passes) < 1:
        got = f"{args.frames}, {args.chunk}, {args.passes}"
        ap.error(f"--frames, --chunk and --passes must be at least 1, got {got}")
    baseline = args.baseline.resolve()
    if (
        not (baseline / MODEL).is_file()
        or not (baseline / "pipeline" / "recognition" / "recognizer.py").is_file()
    ):
        ap.error(f"{args.baseline} is not a cavewalk checkout with a model ({MODEL} missing)")
    out = compare(baseline, args.frames, args.chunk, args.passes)
    print(
        f"update() median per frame: this {out['this_ms']['median']:.3f} ms, "
        f"baseline {out['baseline_ms']['median']:.3f} ms; this / baseline per frame: median "
        f"{out['per_frame_ratio']['median']:.3f} (p25 {out['per_frame_ratio']['p25']:.3f}, "
        f"p75 {out['per_frame_ratio']['p75']:.3f}); {out['frames']} frames, {args.passes} passes"
    )
    print(f"machine: {out['cpu']}")
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
