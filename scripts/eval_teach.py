#!/usr/bin/env python
"""The teach gain (issue 18 item 3): accuracy of the streaming recogniser before and after a
participant's adaptation, on people with unusual styles.

    .venv/bin/python scripts/eval_teach.py [--people 3] [--json OUT] [--mocap DIR ...]

Simulator extremes (pipeline.takes.dataset.EXTREME_STYLES): for each style and person (seed), a
60 s teach take (the shipped ``teach`` protocol) is fitted (``pipeline.takes.teach.fit_adaptation``,
the code behind POST /models/teach), and the person's *other* takes, never seen by the fit, are
scored with the model alone and adapted: the ``four-actions`` and ``no-intent`` protocols (new
motion seeds). Everything is captured through the simulated CAVE cameras (pixel noise, DLT).
Reported too: the held-back part of the teach take (what the product shows the operator).

Real clips (``--mocap DIR``, e.g. ``~/.cache/cavewalk/data/sources/mocap-gaitkit`` from
``cavewalk data sources``): they are not protocol takes of one person, so each clip is held out in
turn and the adaptation is fitted on the source's other clips (leave one clip out), then the clip
is scored before and after.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from pipeline.machine import machine_facts  # noqa: E402
from pipeline.recognition import corpus  # noqa: E402
from pipeline.recognition.evaluation import network_trace, replay, scored  # noqa: E402
from pipeline.recognition.metrics import evaluate  # noqa: E402
from pipeline.recognition.recognizer import DEFAULT_MODEL_PATH, RecognizerConfig, open_session  # noqa: E402
from pipeline.recognition.train import NoiseConfig, captured  # noqa: E402
from pipeline.takes.dataset import EXTREME_STYLES, simulated_participant  # noqa: E402
from pipeline.takes.protocol import load_protocol, shipped_protocols  # noqa: E402
from pipeline.takes.teach import adapted_trace, fit_adaptation, fit_affine, score_sequence  # noqa: E402


def sim_extremes(session: object, config: RecognizerConfig, people: int) -> dict[str, object]:
    shipped = shipped_protocols()
    teach, tests = (
        load_protocol(shipped["teach"]),
        [load_protocol(shipped[n]) for n in ("four-actions", "no-intent")],
    )
    rows = []
    for style, params in EXTREME_STYLES.items():
        for k in range(people):
            seed = 1000 * (list(EXTREME_STYLES).index(style) + 1) + k
            result = fit_adaptation(session, simulated_participant(teach, params, seed), config)
            row: dict[str, object] = {
                "style": style,
                "person": k,
                "held_back_before": result.before["accuracy"],
                "held_back_after": result.after["accuracy"],
                "switched_on": result.helps,
            }
            for j, proto in enumerate(tests):
                seq = simulated_participant(proto, params, seed + 100 * (j + 1))
                b = score_sequence(session, seq, config)
                a = score_sequence(session, seq, config, result.adaptation)
                row[f"{proto.name}_before"], row[f"{proto.name}_after"] = b["accuracy"], a["accuracy"]
                row[f"{proto.name}_fm_before"], row[f"{proto.name}_fm_after"] = (
                    b["false_movement"],
                    a["false_movement"],
                )
                # what the product does: the adaptation only when it did no worse on the held-back part
                row[f"{proto.name}_applied"] = a["accuracy"] if result.helps else b["accuracy"]
            rows.append(row)
            print(json.dumps(row), flush=True)
    return {"rows": rows}


def mocap_loo(session: object, config: RecognizerConfig, folder: Path) -> dict[str, object]:
    seqs = [corpus.resample(s, 30.0) for s in corpus.from_folder(folder)]
    seqs = captured(seqs, NoiseConfig(), seed=7)
    traces = [network_trace(session, s.joints_m, s.fps) for s in seqs]
    rows = []
    for i, (s, tr) in enumerate(zip(seqs, traces, strict=True)):
        others = [j for j in range(len(seqs)) if j != i]
        probs = np.concatenate([traces[j].raw for j in others])
        labels = np.concatenate([seqs[j].labels for j in others])
        if len(set(labels[labels >= 0].tolist())) < 2:
            continue  # the other clips hold one class: nothing to refit
        ad = fit_affine(probs, labels)
        b = evaluate([scored(s, replay(tr, config))])
        a = evaluate([scored(s, replay(adapted_trace(tr, ad), config))])
        rows.append(
            {
                "clip": s.name,
                "frames": b.frames,
                "before": b.accuracy,
                "after": a.accuracy,
                "fm_before": b.overall.false_movement,
                "fm_after": a.overall.false_movement,
            }
        )
        print(json.dumps(rows[-1]), flush=True)
    return {"source": folder.name, "rows": rows}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--people", type=int, default=3, help="simulated people per style")
    ap.add_argument("--mocap", type=Path, action="append", default=[], help="a folder of labelled real clips")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    t0 = time.monotonic()
    session = open_session(DEFAULT_MODEL_PATH)
    config = RecognizerConfig()
    out: dict[str, object] = {
        "machine": machine_facts().summary(),
        "load_before": os.getloadavg(),
        "command": " ".join(sys.argv),
    }
    out["sim"] = sim_extremes(session, config, args.people)
    out["mocap"] = [mocap_loo(session, config, f) for f in args.mocap]
    out["seconds"] = time.monotonic() - t0
    out["load_after"] = os.getloadavg()
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=1, default=str) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
