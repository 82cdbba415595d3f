"""Our simulator's sets of ``cavewalk data sources`` (``pipeline.mocap.sources.SimSet``): kept while
their settings and the simulator stay the same, made again when the simulator's version changes (a
held-out set made by an older simulator gave figures of another set: MODEL_CARD.md, "Latest change")."""

from __future__ import annotations

from pathlib import Path

import pytest

from pipeline.mocap.sources import SimSet, write_sim_set
from pipeline.sim import routines
from pipeline.skeleton import load_npz


def test_a_sim_set_is_kept_until_the_simulator_changes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = tmp_path / "still-heldout"
    spec = SimSet(kind="still", count=1, duration_s=6.0, seed=11)
    index = write_sim_set(folder, spec, progress=lambda _m: None)
    (entry,) = index["files"]
    assert index["stamp"]["sim_version"] == routines.SIM_VERSION
    path = folder / entry["file"]
    seq = load_npz(path)
    assert len(seq) == 180 and set(seq.labels or ()) == {"still"}
    path.write_bytes(path.read_bytes())  # a new modification time; the content as made
    before = path.stat().st_mtime_ns
    made: list[str] = []
    assert write_sim_set(folder, spec, progress=made.append) == index  # kept: nothing made
    assert not made and path.stat().st_mtime_ns == before
    monkeypatch.setattr(routines, "SIM_VERSION", routines.SIM_VERSION + 1)
    again = write_sim_set(folder, spec, progress=made.append)
    assert len(made) == 1, "a new simulator version makes the set again"
    assert again["stamp"]["sim_version"] == routines.SIM_VERSION
