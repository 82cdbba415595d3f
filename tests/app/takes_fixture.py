"""A small finished take folder written through the take's own file functions (no pipeline), with
joints whose values a test knows: two people, one of them the navigator, a protocol's labels."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.takes.files import FRAMES, MANIFEST, finish_take, write_json, write_spans
from pipeline.takes.protocol import label_spans, parse_protocol_text

PROTOCOL = 'name = "tiny"\nsteps = ["still 0.5 s", "forward 0.5 s"]\n'
FPS = 20.0
FRAMES_N = 20
NAVIGATOR, OTHER = 3, 5


def joints_of(user: int, k: int) -> NDArray[np.float64]:
    """(17, 3) CAVE-frame joints of ``user`` at frame ``k``: distinct per joint, axis and frame."""
    j = np.arange(17, dtype=np.float64)[:, None]
    return np.hstack([0.1 * user + 0.01 * j, 1.0 + 0.001 * k + 0.0 * j, 0.05 * j + 0.1]) + 0.0


def make_take(folder: Path, *, uid: str = "tiny-take", unknown_joint_at: int = 4) -> dict[str, Any]:
    """Write and finish the take; frame ``unknown_joint_at`` has the navigator's nose unknown."""
    folder.mkdir(parents=True)
    spans = label_spans(parse_protocol_text(PROTOCOL), margin_s=0.1)
    manifest = {
        "id": uid,
        "take_id": None,
        "participant_code": "T01",
        "source": "simulator",
        "status": "recording",
        "complete": False,
        "start_unix": 1_700_000_000.0,
        "files": {},
        "protocol": parse_protocol_text(PROTOCOL).to_dict(),
    }
    write_json(folder / MANIFEST, manifest)
    write_spans(folder, spans)
    lines = []
    for k in range(FRAMES_N):
        people = []
        for user in (NAVIGATOR, OTHER):
            joints: list[Any] = joints_of(user, k).round(6).tolist()
            if user == NAVIGATOR and k == unknown_joint_at:
                joints[0] = None
            people.append({"user_id": user, "joints": joints, "reproj_px": 1.0})
        lines.append(
            {
                "frame": 100 + k,
                "t": round(k / FPS, 6),
                "ts": 1_700_000_000.0 + k / FPS,
                "views": [],
                "people3d": people,
                "navigator": NAVIGATOR,
                "action": {
                    "label": "still" if k < 10 else "forward",
                    "confidence": 0.9,
                    "probs": {},
                    "yaw_deg": 0.0,
                    "speed_mps": 0.0,
                },
            }
        )
    (folder / FRAMES).write_text("".join(json.dumps(x) + "\n" for x in lines))
    return finish_take(folder, complete=True, manifest=manifest)


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file of a folder, by relative path (to check that nothing changed)."""
    return {
        p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()
    }
