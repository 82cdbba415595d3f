"""The held-out sets of the independent motion models (``pipeline.mocap.sources.BlindSet``): their
checks, and a set of each model with its own capture noise written, indexed and kept while its
settings stay the same."""

from __future__ import annotations

from pathlib import Path

import pytest

from pipeline.errors import InputError
from pipeline.mocap.sources import BLIND_SETS, BlindSet, write_blind_set
from pipeline.skeleton import load_npz


def test_the_sets_name_a_known_model_and_blind2_to_blind7_keep_their_own_noise() -> None:
    assert {s.model for s in BLIND_SETS.values()} == {
        "blind",
        "blind2",
        "blind3",
        "blind4",
        "blind5",
        "blind6",
        "blind7",
    }
    assert BLIND_SETS["blind5-heldout"] == BlindSet(count=12, duration_s=60.0, seed=50505, model="blind5")
    assert BLIND_SETS["blind6-heldout"] == BlindSet(count=12, duration_s=60.0, seed=60606, model="blind6")
    assert BLIND_SETS["blind7-heldout"] == BlindSet(count=12, duration_s=60.0, seed=70707, model="blind7")
    assert BLIND_SETS["blind3-heldout"] == BlindSet(count=12, duration_s=60.0, seed=31337, model="blind3")
    assert BLIND_SETS["blind4-heldout"] == BlindSet(count=12, duration_s=60.0, seed=60606, model="blind4")
    with pytest.raises(InputError, match="model is one of"):
        BlindSet(count=1, duration_s=10.0, seed=1, model="blind8")
    with pytest.raises(InputError, match="blind2 sets have their own capture noise"):
        BlindSet(count=1, duration_s=10.0, seed=1, noise_m=0.0, model="blind2")
    with pytest.raises(InputError, match="blind3 sets have their own capture noise"):
        BlindSet(count=1, duration_s=10.0, seed=1, dropout=0.0, model="blind3")
    with pytest.raises(InputError, match="blind4 sets have their own capture noise"):
        BlindSet(count=1, duration_s=10.0, seed=1, noise_m=0.02, model="blind4")
    with pytest.raises(InputError, match="blind5 sets have their own capture noise"):
        BlindSet(count=1, duration_s=10.0, seed=1, dropout=0.05, model="blind5")
    with pytest.raises(InputError, match="blind6 sets have their own capture noise"):
        BlindSet(count=1, duration_s=10.0, seed=1, noise_m=0.0, model="blind6")
    with pytest.raises(InputError, match="blind7 sets have their own capture noise"):
        BlindSet(count=1, duration_s=10.0, seed=1, dropout=0.0, model="blind7")
    with pytest.raises(InputError, match="count >= 1"):
        BlindSet(count=0, duration_s=10.0, seed=1, model="blind2")


@pytest.mark.parametrize("model", ["blind2", "blind3", "blind4", "blind5", "blind6", "blind7"])
def test_a_set_of_an_own_noise_model_is_written_indexed_and_kept(tmp_path: Path, model: str) -> None:
    folder = tmp_path / f"{model}-heldout"
    spec = BlindSet(count=1, duration_s=10.0, seed=7, model=model)
    index = write_blind_set(folder, spec, progress=lambda _m: None)
    (entry,) = index["files"]
    assert entry["file"] == f"{model}_7_00.npz" and index["stamp"]["model"] == model
    seq = load_npz(folder / entry["file"])
    assert len(seq) == 300 and seq.fps == 30.0 and seq.contacts is not None
    assert sum(entry["frames_per_label"].values()) == 300
    stamp_before = (folder / entry["file"]).stat().st_mtime_ns
    again = write_blind_set(folder, spec, progress=lambda _m: None)  # same settings: kept
    assert again == index and (folder / entry["file"]).stat().st_mtime_ns == stamp_before
    other = write_blind_set(folder, BlindSet(count=1, duration_s=10.0, seed=8, model=model), lambda _m: None)
    assert [f["file"] for f in other["files"]] == [f"{model}_8_00.npz"]  # new settings: made again
    assert not (folder / f"{model}_7_00.npz").exists()
