"""The blind3 generator (pipeline.sim.blind3): its files, its checker, its determinism, its command
line, its independence of the product's code, and a fingerprint of the first file of the held-out
set (seed 31337)."""

from __future__ import annotations

import math
import subprocess
from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import InputError
from pipeline.sim.blind3 import FILE_KEYS, SOURCE, make_record, write_set
from pipeline.sim.blind3.check import check_folder
from pipeline.sim.blind3.kin import leg_angles_for, leg_fk
from pipeline.skeleton import load_npz
from tests.inprocess import run_main
from tests.pipeline.sim.npzfiles import arrays, assert_same_arrays, fingerprint, run_module

REPO = Path(__file__).resolve().parents[3]
PACKAGE = REPO / "pipeline" / "sim" / "blind3"
SEED = 3  # with two 20 s sequences: forward, left and right bouts, a pause and a turn
DURATION_S = 20.0
N_FRAMES = 600

# Sequence 0 of the held-out set (seed 31337, 60 s), measured on blind3_31337_00.npz as the
# standalone generator wrote it: any change to the motion model or its random draws shows here.
FINGERPRINT_00 = {
    "labels": {"forward": 452, "left": 167, "right": 235, "still": 946},
    "tags": {
        "": 398,
        "look": 146,
        "march": 439,
        "pause": 53,
        "point": 68,
        "side-step-out-back": 362,
        "stretch": 135,
        "turn": 199,
    },
    "contacts": [1510, 1502],
    "nan_joints": 612,
    "mean_xyz": [0.07443, -0.04617, 0.9362],
    "sd": 0.51726,
}


@pytest.fixture(scope="module")
def small_set(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """Two 20 s sequences of seed SEED."""
    return write_set(tmp_path_factory.mktemp("blind3"), count=2, seed=SEED, duration_s=DURATION_S)


# ---- files and the checker -----------------------------------------------------------------------


def test_files_have_the_documented_format(small_set: list[Path]) -> None:
    assert [p.name for p in small_set] == [f"blind3_{SEED}_00.npz", f"blind3_{SEED}_01.npz"]
    labels_seen: set[str] = set()
    for path in small_set:
        d = arrays(path)
        assert tuple(d) == FILE_KEYS
        assert d["joints"].dtype == np.float32 and d["joints"].shape == (N_FRAMES, 17, 3)
        assert d["fps"].dtype == np.float64 and d["fps"].shape == () and float(d["fps"]) == 30.0
        assert d["labels"].dtype == np.dtype("<U7") and d["labels"].shape == (N_FRAMES,)
        assert d["tags"].dtype == np.dtype("<U20") and d["tags"].shape == (N_FRAMES,)
        assert d["contacts"].dtype == np.bool_ and d["contacts"].shape == (N_FRAMES, 2)
        assert d["source"].shape == () and str(d["source"]) == SOURCE == "blind3"
        assert set(d["labels"].tolist()) <= {"still", "forward", "left", "right"}
        labels_seen |= set(d["labels"].tolist())
        seq = load_npz(path)  # the product's reader takes the files as they are
        assert len(seq) == N_FRAMES and seq.source == SOURCE
    assert labels_seen == {"still", "forward", "left", "right"}, "the fixture has every kind of bout"


def test_the_checker_passes_the_generated_set(small_set: list[Path]) -> None:
    assert check_folder(small_set[0].parent) == []


def _tamper(d: dict[str, np.ndarray], how: str) -> None:
    if how == "labels":
        d["labels"] = d["labels"].copy()
        d["labels"][10] = "forward"  # the first second is plain standing
    elif how == "contacts":
        d["contacts"] = d["contacts"].copy()
        d["contacts"][100:110, 0] = ~d["contacts"][100:110, 0]
    elif how == "offset":
        d["joints"] = d["joints"] + np.float32(0.05)  # the whole body 5 cm off the model
    elif how == "noise":
        d["joints"] = d["joints"] + np.random.default_rng(0).normal(0, 0.02, d["joints"].shape).astype(
            np.float32
        )
    elif how == "partial-nan":
        d["joints"] = d["joints"].copy()
        d["joints"][200, 5, 0] = np.nan
    elif how == "no-drop-outs":
        d["joints"] = np.nan_to_num(d["joints"], nan=0.5)
    elif how == "dtype":
        d["joints"] = d["joints"].astype(np.float64)
    elif how == "source":
        d["source"] = np.array("blind2")
    elif how == "missing":
        del d["contacts"]
    else:
        raise AssertionError(how)


@pytest.mark.parametrize(
    ("how", "expected"),
    [
        ("labels", "labels == model"),
        ("contacts", "contacts == model"),
        ("offset", "noise"),
        ("noise", "noise"),
        ("partial-nan", "NaN whole joints"),
        ("no-drop-outs", "drop rate"),
        ("dtype", "joints"),
        ("source", "source"),
        ("missing", "keys"),
    ],
)
def test_the_checker_finds_a_tampered_file(
    small_set: list[Path], tmp_path: Path, how: str, expected: str
) -> None:
    d = arrays(small_set[0])
    _tamper(d, how)
    np.savez(tmp_path / small_set[0].name, **d)
    problems = check_folder(tmp_path)
    assert problems, f"the checker misses a file with tampered {how}"
    assert any(expected in p for p in problems), problems


def test_the_checker_finds_an_empty_folder_a_misnamed_file_and_a_file_under_another_index(
    small_set: list[Path], tmp_path: Path
) -> None:
    assert any("no blind3_*.npz" in p for p in check_folder(tmp_path))
    misnamed = tmp_path / f"blind3_{SEED}_first.npz"
    np.savez(misnamed, **arrays(small_set[0]))
    assert any("unexpected file name" in p for p in check_folder(tmp_path))
    misnamed.unlink()
    # file 00's arrays under the name of file 01: they are not what the generator makes for index 1
    np.savez(tmp_path / f"blind3_{SEED}_01.npz", **arrays(small_set[0]))
    problems = check_folder(tmp_path)
    assert any("labels == model" in p for p in problems) and any("noise" in p for p in problems), problems


# ---- determinism ---------------------------------------------------------------------------------


def test_two_runs_give_equal_files(small_set: list[Path], tmp_path: Path) -> None:
    again = write_set(tmp_path, count=2, seed=SEED, duration_s=DURATION_S)
    for a, b in zip(small_set, again, strict=True):
        assert a.name == b.name
        assert_same_arrays(arrays(a), arrays(b))
        assert a.read_bytes() == b.read_bytes(), "two runs give byte-identical files"


def test_a_sequence_depends_on_seed_and_index_only(small_set: list[Path], tmp_path: Path) -> None:
    # the same sequence whatever the count of its set ...
    (alone,) = write_set(tmp_path, count=1, seed=SEED, duration_s=DURATION_S)
    assert_same_arrays(arrays(alone), arrays(small_set[0]))
    # ... and generated on its own from (seed, index)
    rec = make_record(SEED, 1, DURATION_S, 30.0)[0]
    assert_same_arrays(rec, arrays(small_set[1]))
    # a different index or seed is a different person doing different things
    for seed, idx in ((SEED, 2), (SEED + 1, 1)):
        other = make_record(seed, idx, DURATION_S, 30.0)[0]
        assert not np.allclose(other["joints"], rec["joints"], equal_nan=True), (seed, idx)


def test_sequence_0_of_the_held_out_set_matches_its_fingerprint() -> None:
    d = make_record(31337, 0, 60.0, 30.0)[0]
    assert fingerprint(d) == FINGERPRINT_00, "the motion model or its random draws changed"


# ---- the leg chain -------------------------------------------------------------------------------


def test_the_closed_form_leg_chain_inverts_forward_kinematics() -> None:
    rng = np.random.default_rng(0)
    for i in range(500):
        side = i % 2
        th, al, rh, ka = (
            rng.uniform(-0.5, 0.8),
            rng.uniform(-0.4, 0.6),
            rng.uniform(-0.6, 0.6),
            rng.uniform(0.05, 1.5),
        )
        _, ankle = leg_fk(side, th, al, rh, ka, 0.43, 0.44)
        th2, al2, ka2 = leg_angles_for(side, *ankle, rh, 0.43, 0.44)
        assert max(abs(th - th2), abs(al - al2), abs(ka - ka2)) < 1e-9, (side, th, al, rh, ka)
    # conventions: x right, y forward; abduction moves the left foot to -x, the right foot to +x
    assert leg_fk(0, 0.0, 0.3, 0.0, 0.0, 0.43, 0.44)[1][0] < -0.1
    assert leg_fk(1, 0.0, 0.3, 0.0, 0.0, 0.43, 0.44)[1][0] > 0.1
    knee = leg_fk(0, 0.5, 0.0, 0.0, 0.0, 0.43, 0.44)[0]
    assert knee[1] == pytest.approx(0.43 * math.sin(0.5)), "hip flexion moves the knee forward"


# ---- command line --------------------------------------------------------------------------------


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return run_module("pipeline.sim.blind3", *args)


def run_in_process(*args: str) -> subprocess.CompletedProcess[str]:
    """The same command line without starting an interpreter (for the refusals)."""
    return run_main("pipeline.sim.blind3", *args)


def test_cli_writes_a_set(tmp_path: Path) -> None:
    out = tmp_path / "set"
    r = run_cli(str(out), "--count", "2", "--seed", "5", "--duration", "2")
    assert r.returncode == 0, r.stderr
    paths = [out / "blind3_5_00.npz", out / "blind3_5_01.npz"]
    assert r.stdout.splitlines() == [str(p) for p in paths] and r.stderr == ""
    assert sorted(out.iterdir()) == paths
    assert_same_arrays(arrays(paths[1]), make_record(5, 1, 2.0, 30.0)[0])


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--count", "0"], "count must be"),
        (["--count", "-3"], "count must be"),
        (["--count", "two"], "invalid int value"),
        (["--duration", "0"], "duration must be"),
        (["--duration", "-5"], "duration must be"),
        (["--duration", "nan"], "duration must be"),
        (["--duration", "0.5"], "duration must be"),
        (["--seed", "-1"], "seed must be"),
        (["--bogus"], "unrecognized arguments"),
    ],
)
def test_cli_refuses_bad_arguments(tmp_path: Path, args: list[str], match: str) -> None:
    out = tmp_path / "set"
    r = run_in_process(str(out), *args)
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert r.stderr.count("\n") == 1 and r.stderr.startswith("error: ") and match in r.stderr, r.stderr
    assert r.stdout == ""
    assert list(tmp_path.iterdir()) == [], "a refused set writes nothing"


def test_cli_refuses_a_file_as_out_dir_and_a_missing_one(tmp_path: Path) -> None:
    taken = tmp_path / "taken"
    taken.write_text("keep me")
    for out, match in ((taken, "not a folder"), (taken / "set", "error: ")):
        r = run_in_process(str(out), "--count", "1", "--duration", "2")
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and r.stderr.startswith("error: "), r.stderr
        assert match in r.stderr and "Traceback" not in r.stderr
        assert taken.read_text() == "keep me" and sorted(tmp_path.iterdir()) == [taken]
    r = run_in_process()
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and r.stderr.startswith("error: ")
    assert "out_dir" in r.stderr


@pytest.mark.parametrize(
    "kwargs",
    [{"count": 0}, {"count": 2.5}, {"seed": -1}, {"duration_s": 0.0}, {"duration_s": float("inf")}],
)
def test_write_set_refuses_bad_values_before_writing(tmp_path: Path, kwargs: dict[str, float]) -> None:
    with pytest.raises(InputError):
        write_set(tmp_path / "set", **kwargs)  # type: ignore[arg-type]
    assert list(tmp_path.iterdir()) == []
