"""Tiny labelled take folders for the training tests: simulated people (the simulator's routines,
captured through the simulated CAVE cameras with their noise) written as takes by
:func:`pipeline.takes.dataset.write_take`, and indexed like a server's takes."""

from __future__ import annotations

import json
from pathlib import Path

from sqlalchemy.orm import Session

from app.db.take_repository import create_take, finish_take_row
from pipeline.recognition import corpus
from pipeline.recognition.train import NoiseConfig, captured
from pipeline.takes.dataset import write_take
from pipeline.takes.files import relabel_take


def simulated_takes(
    root: Path, participants: int = 2, duration_s: float = 12.0, seed: int = 11
) -> list[Path]:
    """One take per participant (P1, P2, ...) of a mixed routine, labelled from the simulator's truth."""
    seqs = captured(
        corpus.simulated(participants, duration_s, 30.0, seed, kinds=("mixed",)), NoiseConfig(), seed
    )
    return [write_take(root / f"take-P{i + 1}-s{seed}", s, f"P{i + 1}") and root / f"take-P{i + 1}-s{seed}"
            for i, s in enumerate(seqs)]  # fmt: skip


def unlabelled_take(root: Path) -> Path:
    """A take whose labels were all removed (no spans: no labels in its skeletons)."""
    (folder,) = simulated_takes(root, participants=1, duration_s=6.0, seed=5)
    relabel_take(folder, [])
    return folder


def one_heldout_source(cache: Path) -> None:
    """What `cavewalk data sources` leaves for a fine-tuned model's card, in the cache folder ``cache``:
    a manifest naming an eval-only folder (one short clip of the third motion model here). A test that
    trains gives its worker this cache, not the user's: the card evaluates every held-out source it
    finds there."""
    from pipeline.mocap.sources import MANIFEST, BlindSet, sources_dir, write_blind_set

    folder = sources_dir(cache) / "blind-heldout"
    write_blind_set(folder, BlindSet(count=1, duration_s=8.0, seed=5), progress=lambda _m: None)
    manifest = {
        "blind-heldout": {"dir": str(folder), "use": "eval"},
        "gait": {"dir": str(folder), "use": "train"},
    }
    (sources_dir(cache) / MANIFEST).write_text(json.dumps(manifest))


def index_takes(db: Session, folders: list[Path]) -> list[int]:
    """The takes as rows of the takes index (what a server's recorder writes)."""
    from pipeline.takes.files import load_manifest

    ids = []
    for f in folders:
        m = load_manifest(f)
        code = m.get("participant_code")
        row = create_take(db, uid=m["id"], folder=str(f), status="recording", participant_code=code, files={})
        finish_take_row(db, row.id, m, "complete")
        ids.append(row.id)
    return ids


def teach_take(root: Path, participant: str, style: str = "slow-with-pauses", seed: int = 100) -> Path:
    """A simulated participant in an unusual style following the shipped 60 s teach protocol."""
    from pipeline.takes.dataset import EXTREME_STYLES, simulated_participant
    from pipeline.takes.protocol import load_protocol, shipped_protocols

    seq = simulated_participant(load_protocol(shipped_protocols()["teach"]), EXTREME_STYLES[style], seed)
    folder = root / f"teach-{participant}"
    write_take(folder, seq, participant)
    return folder
