"""`fetch_mocap` on the real pinned pybullet sdist (downloads once into the user cache)."""

from __future__ import annotations

import json
import time
from typing import Any

import numpy as np
import pytest

from pipeline.mocap import fetch_mocap, load_index
from pipeline.skeleton import J, load_npz

pytestmark = pytest.mark.slow


def test_real_clips_are_converted_labelled_and_indexed(base_settings: Any) -> None:
    cache = base_settings.paths.cache_dir
    paths = fetch_mocap(cache)
    index = load_index(cache)
    assert [p.name for p in paths] == [c["file"] for c in index["clips"]]
    by_id = {c["id"]: c for c in index["clips"]}
    assert by_id["deepmimic-walk"]["package"] == "pybullet==3.2.7"
    for path in paths:
        seq = load_npz(path)
        assert seq.fps == 30.0 and seq.source == path.stem and seq.contacts is not None
        assert seq.labels is not None and seq.tags is not None
        assert np.isfinite(seq.joints_m).all()
        counts = by_id[path.stem]["frames_per_label"]
        assert sum(counts.values()) == len(seq)
    walk = load_npz(cache / "data" / "mocap" / "deepmimic-walk.npz")
    ank = walk.joints_m[:, [J["l_ankle"], J["r_ankle"]], 2]
    assert 0.03 < np.percentile(ank, 5) < 0.12  # ankles just above the floor in stance
    head = walk.joints_m[:, J["nose"], 2]
    assert 1.4 < np.median(head) < 1.7
    assert walk.labels is not None and walk.labels.count("forward") == len(walk)
    assert walk.contacts is not None and walk.contacts.any(axis=1).mean() > 0.9  # walking: a foot down
    jump = load_npz(cache / "data" / "mocap" / "deepmimic-jump.npz")
    assert jump.labels is not None and set(jump.labels) == {"still"}
    assert jump.contacts is not None and (~jump.contacts.any(axis=1)).sum() > 10  # a real flight phase
    kick = load_npz(cache / "data" / "mocap" / "deepmimic-kick.npz")
    assert kick.labels is not None and {"still", "ignore"} == set(kick.labels)
    # Idempotent: the second call reuses what is there.
    mtimes = [p.stat().st_mtime for p in paths]
    time.sleep(0.01)
    again = fetch_mocap(cache)
    assert again == paths and [p.stat().st_mtime for p in again] == mtimes
    assert json.loads((cache / "data" / "mocap" / "index.json").read_text())["fps"] == 30.0
