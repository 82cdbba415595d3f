"""The blind6 generator (pipeline.sim.blind6, the eighth motion model): its files, its own checker
(which must pass on what it writes and fail on a file that breaks its laws), its determinism, its
refusals, its command line and a fingerprint of the first file of the held-out set (seed 60606)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import InputError
from pipeline.sim.blind6 import make_record, write_set
from pipeline.sim.blind6.check import check_file
from pipeline.skeleton import load_npz
from tests.pipeline.sim.npzfiles import arrays, assert_same_arrays, fingerprint, run_module

# Sequence 0 of the held-out set (seed 60606, 60 s), measured on blind6_60606_00.npz as the
# standalone generator wrote it: any change to the motion model or its random draws shows here.
FINGERPRINT_00 = {
    "labels": {"forward": 525, "left": 75, "right": 90, "still": 1110},
    "tags": {
        "": 394,
        "bow": 56,
        "gesture": 78,
        "idle": 45,
        "look-around": 97,
        "march": 507,
        "pause": 53,
        "side-step-out-back": 55,
        "step-touch": 75,
        "stretch": 214,
        "sway": 70,
        "weight-shift": 156,
    },
    "contacts": [1558, 1509],
    "nan_joints": 612,
    "mean_xyz": [-0.0833, -0.14627, 1.15143],
    "sd": 0.69098,
}


def _check(path: Path) -> list[str]:
    return check_file(path, {"frames": {}, "bouts": {}, "tags": {}})


@pytest.fixture(scope="module")
def small_set(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    return write_set(tmp_path_factory.mktemp("blind6"), count=2, seed=146, duration_s=20.0)


def test_files_are_labelled_skeletons_that_pass_the_generators_own_check(small_set: list[Path]) -> None:
    for path in small_set:
        seq = load_npz(path)  # the product's reader takes them
        assert len(seq) == 600 and seq.fps == 30.0 and seq.contacts is not None
        assert set(seq.labels or ()) <= {"still", "forward", "left", "right"}
        errors = _check(path)
        assert errors == [], errors
    labels = np.concatenate([np.asarray(load_npz(p).labels) for p in small_set])
    assert {"still", "forward", "left", "right"} <= set(labels.tolist())


def test_the_check_fails_a_file_that_breaks_the_label_law(small_set: list[Path], tmp_path: Path) -> None:
    d = arrays(small_set[0])
    moving = np.flatnonzero(d["labels"] != "still")
    d["labels"] = d["labels"].copy()
    d["labels"][moving[:5]] = "still"  # a bout that no longer starts at its lift-off
    bad = tmp_path / small_set[0].name
    np.savez(bad, **d)  # type: ignore[arg-type]
    assert _check(bad), "the check must see the change"


def test_a_sequence_depends_on_seed_index_and_duration_only(small_set: list[Path]) -> None:
    assert_same_arrays(arrays(small_set[1]), make_record(146, 1, 600))
    assert not np.array_equal(make_record(147, 1, 600)["labels"], arrays(small_set[1])["labels"])


def test_the_first_file_of_the_held_out_set_is_the_one_measured(tmp_path: Path) -> None:
    (path,) = write_set(tmp_path, count=1, seed=60606, duration_s=60.0)
    assert fingerprint(arrays(path)) == FINGERPRINT_00


def test_bad_arguments_are_refused_before_anything_is_written(tmp_path: Path) -> None:
    for kwargs, words in (
        ({"count": 0}, "count must be"),
        ({"seed": -1}, "seed must be"),
        ({"duration_s": 5.0}, "duration must be"),
    ):
        with pytest.raises(InputError, match=words):
            write_set(tmp_path / "out", **kwargs)  # type: ignore[arg-type]
    assert not (tmp_path / "out").exists()
    done = run_module("pipeline.sim.blind6", str(tmp_path / "out"), "--count", "0")
    assert done.returncode == 2 and done.stderr.startswith("error: count must be") and not done.stdout
    done = run_module("pipeline.sim.blind6", str(tmp_path / "out"), "--seed", "x")
    assert done.returncode == 2 and done.stderr.startswith("error: seed must be") and not done.stdout
    assert not (tmp_path / "out").exists()
    (tmp_path / "file").write_text("x")
    done = run_module("pipeline.sim.blind6", str(tmp_path / "file"), "--count", "1", "--duration", "10")
    assert (
        done.returncode == 2
        and done.stderr.startswith("error: cannot write")
        and done.stderr.count("\n") == 1
    )
    done = run_module("pipeline.sim.blind6.check", str(tmp_path / "empty"))
    assert done.returncode == 2 and done.stderr.startswith("error: ")
