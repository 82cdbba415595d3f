"""The blind5, blind6 and blind7 generators (pipeline.sim.blind5 to blind7, the seventh to ninth
motion models): their files, their own checkers (which must pass on what they write and fail on a
file that breaks their laws), their determinism, their refusals, their command lines and a
fingerprint of the first file of each held-out set (blind5 seed 50505, blind6 seed 60606, blind7
seed 70707)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pipeline.errors import InputError
from pipeline.sim import blind5, blind6, blind7
from pipeline.sim.blind5.check import check_file as check5
from pipeline.sim.blind6.check import check_file as check6
from pipeline.sim.blind7.check import check_file as check7
from pipeline.skeleton import load_npz
from tests.inprocess import run_main
from tests.pipeline.sim.npzfiles import arrays, assert_same_arrays, fingerprint, run_module


@dataclass(frozen=True)
class Generator:
    module: Any
    check: Callable[[Path], list[str]]
    held_out_seed: int
    duration_words: str  # how its refusal names the duration
    fingerprint_00: dict[str, object]  # the held-out set's first file as the standalone generator wrote it


# Sequence 0 of each held-out set (60 s), measured on the file the standalone generator wrote: any
# change to the motion model or its random draws shows here.
GENERATORS = {
    "blind5": Generator(
        blind5,
        lambda path: check5(path)[0],
        50505,
        "duration_s must be",
        {
            "labels": {"forward": 261, "left": 378, "right": 184, "still": 977},
            "tags": {
                "": 307,
                "bow": 157,
                "idle": 149,
                "march": 229,
                "pause": 121,
                "side-step-out-back": 131,
                "step-touch": 360,
                "tiptoe": 158,
                "turn": 132,
                "weight-shift": 56,
            },
            "contacts": [1531, 1450],
            "nan_joints": 612,
            "mean_xyz": [0.24294, 0.11485, 0.97842],
            "sd": 0.48995,
        },
    ),
    "blind6": Generator(
        blind6,
        lambda path: check6(path, {"frames": {}, "bouts": {}, "tags": {}}),
        60606,
        "duration must be",
        {
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
        },
    ),
    "blind7": Generator(
        blind7,
        check7,
        70707,
        "duration_s must be",
        {
            "labels": {"forward": 301, "left": 277, "right": 288, "still": 934},
            "tags": {
                "": 288,
                "bow": 93,
                "heel_kick": 122,
                "lean": 37,
                "look_around": 151,
                "march": 70,
                "pause": 319,
                "shuffle": 152,
                "squat": 108,
                "step_together": 203,
                "sway": 81,
                "tiptoe": 58,
                "turn": 79,
                "weight_shift": 39,
            },
            "contacts": [1521, 1519],
            "nan_joints": 616,
            "mean_xyz": [-0.03602, -0.08939, 1.0103],
            "sd": 0.58916,
        },
    ),
}


@pytest.fixture(scope="module", params=sorted(GENERATORS))
def model(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture(scope="module")
def small_set(model: str, tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    return GENERATORS[model].module.write_set(
        tmp_path_factory.mktemp(model), count=2, seed=146, duration_s=20.0
    )


def test_files_are_labelled_skeletons_that_pass_the_generators_own_check(
    model: str, small_set: list[Path]
) -> None:
    for path in small_set:
        seq = load_npz(path)  # the product's reader takes them
        assert len(seq) == 600 and seq.fps == 30.0 and seq.contacts is not None
        assert set(seq.labels or ()) <= {"still", "forward", "left", "right"}
        errors = GENERATORS[model].check(path)
        assert errors == [], errors
    labels = np.concatenate([np.asarray(load_npz(p).labels) for p in small_set])
    assert {"still", "forward", "left", "right"} <= set(labels.tolist())


def test_the_check_fails_a_file_that_breaks_the_label_law(
    model: str, small_set: list[Path], tmp_path: Path
) -> None:
    d = arrays(small_set[0])
    moving = np.flatnonzero(d["labels"] != "still")
    d["labels"] = d["labels"].copy()
    d["labels"][moving[:5]] = "still"  # a bout that no longer starts at its lift-off
    bad = tmp_path / small_set[0].name
    np.savez(bad, **d)  # type: ignore[arg-type]
    assert GENERATORS[model].check(bad), "the check must see the change"


def test_a_sequence_depends_on_seed_index_and_duration_only(model: str, small_set: list[Path]) -> None:
    make_record = GENERATORS[model].module.make_record
    assert_same_arrays(arrays(small_set[1]), make_record(146, 1, 600))
    assert not np.array_equal(make_record(147, 1, 600)["labels"], arrays(small_set[1])["labels"])


def test_the_first_file_of_the_held_out_set_is_the_one_measured(model: str, tmp_path: Path) -> None:
    gen = GENERATORS[model]
    (path,) = gen.module.write_set(tmp_path, count=1, seed=gen.held_out_seed, duration_s=60.0)
    assert fingerprint(arrays(path)) == gen.fingerprint_00


def test_bad_arguments_are_refused_before_anything_is_written(model: str, tmp_path: Path) -> None:
    gen, module = GENERATORS[model], f"pipeline.sim.{model}"
    for kwargs, words in (
        ({"count": 0}, "count must be"),
        ({"seed": -1}, "seed must be"),
        ({"duration_s": 5.0}, gen.duration_words),
    ):
        with pytest.raises(InputError, match=words):
            gen.module.write_set(tmp_path / "out", **kwargs)
    assert not (tmp_path / "out").exists()
    done = run_module(module, str(tmp_path / "out"), "--count", "0")
    assert done.returncode == 2 and done.stderr.startswith("error: count must be") and not done.stdout
    done = run_main(module, str(tmp_path / "out"), "--seed", "x")  # the same command line in-process
    assert done.returncode == 2 and done.stderr.startswith("error: ") and not done.stdout
    assert not (tmp_path / "out").exists()
    (tmp_path / "file").write_text("x")
    done = run_main(module, str(tmp_path / "file"), "--count", "1", "--duration", "10")
    assert (
        done.returncode == 2
        and done.stderr.startswith("error: cannot write")
        and done.stderr.count("\n") == 1
    )
    done = run_main(f"{module}.check", str(tmp_path / "empty"))
    assert done.returncode == 2 and done.stderr.startswith("error: ")
