"""Reading and comparing the independent motion models' NPZ files and running their command lines,
for their tests."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[3]


def arrays(path: Path) -> dict[str, np.ndarray]:
    """Every array of an NPZ file, by key, in the file's order."""
    with np.load(path, allow_pickle=False) as d:
        return {k: d[k] for k in d.files}


def assert_same_arrays(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> None:
    """The same keys in the same order, and equal arrays (dtype, shape, values; NaN equal to NaN)."""
    assert list(a) == list(b)
    for k in a:
        assert a[k].dtype == b[k].dtype and a[k].shape == b[k].shape, k
        assert np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind == "f"), f"{k} differs"


def run_module(module: str, *args: str) -> subprocess.CompletedProcess[str]:
    """``python -m module args...`` from the repository's root (a generator's command line)."""
    return subprocess.run(
        [sys.executable, "-m", module, *args], cwd=REPO, capture_output=True, text=True, timeout=120
    )


def fingerprint(d: dict[str, np.ndarray]) -> dict[str, object]:
    """A record's label and tag counts, contact counts, unknown joints and joint statistics."""
    labels, n_labels = np.unique(d["labels"], return_counts=True)
    tags, n_tags = np.unique(d["tags"], return_counts=True)
    x = d["joints"].astype(np.float64)
    return {
        "labels": dict(zip(labels.tolist(), n_labels.tolist(), strict=True)),
        "tags": dict(zip(tags.tolist(), n_tags.tolist(), strict=True)),
        "contacts": d["contacts"].sum(0).tolist(),
        "nan_joints": int(np.isnan(x).any(-1).sum()),
        "mean_xyz": np.round(np.nanmean(x, axis=(0, 1)), 5).tolist(),
        "sd": round(float(np.nanstd(x)), 5),
    }
