"""The blind4 generator (pipeline.sim.blind4): its files, its labels against its contacts, its rigid
bones, its side steps, its checker, its determinism, its refusals, its command line, its independence
of the product's code, and a fingerprint of the first file of the held-out set (seed 60606)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import InputError
from pipeline.sim.blind4 import (
    DEFAULT_COUNT,
    DEFAULT_DURATION_S,
    DEFAULT_SEED,
    FILE_KEYS,
    FPS,
    SOURCE,
    CleanSequence,
    file_name,
    generate,
    generate_clean,
    write_set,
)
from pipeline.sim.blind4.__main__ import main as write_main
from pipeline.sim.blind4.check import check_folder
from pipeline.sim.blind4.check import main as check_main
from pipeline.skeleton import load_npz
from tests.inprocess import run_main
from tests.pipeline.sim.npzfiles import arrays, assert_same_arrays, fingerprint, run_module

REPO = Path(__file__).resolve().parents[3]
PACKAGE = REPO / "pipeline" / "sim" / "blind4"
# with two 20 s sequences: forward, left and right bouts; marches, shuffles, side steps out and back
# and step-togethers; a pause, turns (still frames with a foot in the air) and weight shifts
SEED = 146
DURATION_S = 20.0
N_FRAMES = 600
N_MORE = 8  # sequences for the label and direction laws
LEFT_JOINTS = [1, 3, 5, 7, 9, 11, 13, 15]  # COCO-17: l_eye, l_ear, l_shoulder ... l_ankle
RIGHT_JOINTS = [2, 4, 6, 8, 10, 12, 14, 16]

# Sequence 0 of the held-out set (seed 60606, 60 s), measured on blind4_60606_00.npz as the
# standalone generator wrote it: any change to the motion model or its random draws shows here.
FINGERPRINT_00 = {
    "labels": {"forward": 375, "left": 390, "right": 150, "still": 885},
    "tags": {
        "": 585,
        "idle": 50,
        "look-around": 203,
        "march": 362,
        "pause": 30,
        "shuffle": 63,
        "side-step-out-back": 67,
        "step-together": 393,
        "turn": 47,
    },
    "contacts": [1456, 1501],
    "nan_joints": 612,
    "mean_xyz": [0.076, 0.11607, 0.94106],
    "sd": 0.50523,
}


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Maximal runs [a, b) of True in a 1-D mask."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(), strict=True))


@pytest.fixture(scope="module")
def small_set(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """Two 20 s sequences of seed SEED."""
    return write_set(tmp_path_factory.mktemp("blind4"), count=2, seed=SEED, duration_s=DURATION_S)


@pytest.fixture(scope="module")
def clean_set() -> list[CleanSequence]:
    """The noise-free sequences behind ``small_set``."""
    return [generate_clean(SEED, i, DURATION_S) for i in range(2)]


@pytest.fixture(scope="module")
def more_sequences(
    small_set: list[Path], clean_set: list[CleanSequence]
) -> list[tuple[str, dict[str, np.ndarray], CleanSequence]]:
    """Eight 20 s sequences of seed SEED (the two files, then six more in memory): name, arrays, clean."""
    seqs = [(p.name, arrays(p), c) for p, c in zip(small_set, clean_set, strict=True)]
    for i in range(2, N_MORE):
        seqs.append((file_name(SEED, i), generate(SEED, i, DURATION_S), generate_clean(SEED, i, DURATION_S)))
    return seqs


# ---- files ---------------------------------------------------------------------------------------


def test_the_public_constants() -> None:
    assert (DEFAULT_SEED, DEFAULT_COUNT, DEFAULT_DURATION_S, FPS, SOURCE) == (60606, 12, 60.0, 30.0, "blind4")
    assert FILE_KEYS == ("joints", "fps", "labels", "tags", "contacts", "source")
    assert file_name(60606, 3) == "blind4_60606_03.npz" and file_name(7, 12) == "blind4_7_12.npz"


def test_files_have_the_documented_format(small_set: list[Path]) -> None:
    assert [p.name for p in small_set] == [f"blind4_{SEED}_00.npz", f"blind4_{SEED}_01.npz"]
    labels_seen: set[str] = set()
    tags_seen: set[str] = set()
    for path in small_set:
        d = arrays(path)
        assert tuple(d) == FILE_KEYS
        assert d["joints"].dtype == np.float32 and d["joints"].shape == (N_FRAMES, 17, 3)
        assert d["fps"].dtype == np.float64 and d["fps"].shape == () and float(d["fps"]) == 30.0
        assert d["labels"].dtype == np.dtype("<U7") and d["labels"].shape == (N_FRAMES,)
        assert d["tags"].dtype == np.dtype("<U20") and d["tags"].shape == (N_FRAMES,)
        assert d["contacts"].dtype == np.bool_ and d["contacts"].shape == (N_FRAMES, 2)
        assert d["source"].shape == () and str(d["source"]) == SOURCE == "blind4"
        nan = np.isnan(d["joints"])
        assert (nan.any(-1) == nan.all(-1)).all(), "a dropped joint loses all three coordinates"
        assert 0.015 <= nan.any(-1).mean() <= 0.025, "about 2 % of the joints are dropped"
        labels_seen |= set(d["labels"].tolist())
        tags_seen |= set(d["tags"].tolist())
        seq = load_npz(path)  # the product's reader takes the files as they are
        assert len(seq) == N_FRAMES and seq.source == SOURCE
    assert labels_seen == {"still", "forward", "left", "right"}, "the fixture has every kind of bout"
    assert {"march", "shuffle", "side-step-out-back", "step-together", "pause", "turn", "weight-shift"} <= (
        tags_seen
    ), "the fixture has every kind of stepping and both still behaviours that lift a foot"


# ---- labels, contacts, bones and directions (on the files and their noise-free skeletons) -------------


def test_labels_agree_with_the_contacts(
    more_sequences: list[tuple[str, dict[str, np.ndarray], CleanSequence]],
) -> None:
    still_in_the_air = 0
    n_bouts = 0
    for name, d, _ in more_sequences:
        labels, tags, contacts = d["labels"], d["tags"], d["contacts"]
        assert contacts.any(1).all(), "never both feet in the air"
        airborne = ~contacts.all(1)
        still = labels == "still"
        in_the_air = still & airborne
        assert set(tags[in_the_air].tolist()) <= {"turn", "weight-shift"}, "a still frame with a step"
        still_in_the_air += int(in_the_air.sum())
        assert set(tags[still].tolist()).isdisjoint({"march", "shuffle", "side-step-out-back", "pause"})
        previous_end = None
        for a, b in runs(~still):  # bout frames a .. b-1
            n_bouts += 1
            assert len(set(labels[a:b].tolist())) == 1, f"{name}: bout {a}-{b} mixes labels"
            lift_off = [f for f in range(2) if contacts[a - 1, f] and not contacts[a, f]]
            touch_down = [f for f in range(2) if not contacts[b - 2, f] and contacts[b - 1, f]]
            assert lift_off, f"{name}: bout {a}-{b} starts at the first frame a foot is off the floor"
            assert touch_down, f"{name}: bout {a}-{b} ends at the first frame a foot is back"
            assert 2.0 <= (b - a) / FPS <= 10.05, f"{name}: bout {a}-{b} lasts {(b - a) / FPS} s"
            for a2, b2 in runs(contacts[a:b].all(1)):
                assert b2 - a2 <= FPS, f"{name}: {b2 - a2} frames of double support in bout {a}"
            if previous_end is not None:
                assert a - previous_end >= 1.5 * FPS, f"{name}: still gap before {a} under 1.5 s"
            previous_end = b
    assert n_bouts >= 12 and still_in_the_air > 0, (n_bouts, still_in_the_air)


BONES = {
    "l_thigh": (11, 13, "thigh"),
    "r_thigh": (12, 14, "thigh"),
    "l_shank": (13, 15, "shank"),
    "r_shank": (14, 16, "shank"),
    "l_upper_arm": (5, 7, "upper_arm"),
    "r_upper_arm": (6, 8, "upper_arm"),
    "l_forearm": (7, 9, "forearm"),
    "r_forearm": (8, 10, "forearm"),
    "hips": (11, 12, "hip_half"),
    "shoulders": (5, 6, "shoulder_half"),
    "eyes": (1, 2, ""),
    "ears": (3, 4, ""),
    "nose_l_ear": (0, 3, ""),
}


def test_bones_keep_the_body_s_lengths_on_the_clean_skeleton(
    small_set: list[Path], clean_set: list[CleanSequence]
) -> None:
    for path, clean in zip(small_set, clean_set, strict=True):
        j = clean.joints
        assert j.shape == (N_FRAMES, 17, 3) and np.isfinite(j).all()
        for name, (a, b, dim) in BONES.items():
            length = np.linalg.norm(j[:, a] - j[:, b], axis=-1)
            assert np.ptp(length) < 1e-9, f"{path.name}: {name} varies by {np.ptp(length):.2e} m"
            if dim:
                want = getattr(clean.body, dim) * (2.0 if dim.endswith("_half") else 1.0)
                assert length[0] == pytest.approx(want, abs=1e-9), f"{path.name}: {name}"
        assert clean.ik_clamped == 0, "no leg target out of reach"
        # the file is that skeleton plus about 1.2 cm of noise per coordinate
        observed = arrays(path)["joints"].astype(np.float64)
        residual = (observed - j)[~np.isnan(observed)]
        assert 0.0108 <= residual.std() <= 0.0132 and abs(residual.mean()) < 1e-3


def test_side_bouts_move_the_foot_on_the_labelled_side_to_that_side(
    more_sequences: list[tuple[str, dict[str, np.ndarray], CleanSequence]],
) -> None:
    side_bouts = {"left": 0, "right": 0}
    for name, d, clean in more_sequences:
        labels, contacts = d["labels"], d["contacts"]
        ankles, hips = clean.joints[:, 15:17], clean.joints[:, 11:13]
        for a, _ in runs(labels != "still"):
            label = str(labels[a])
            lifted = [f for f in range(2) if contacts[a - 1, f] and not contacts[a, f]]
            assert len(lifted) == 1, f"{name}: one foot opens bout {a}"
            foot = lifted[0]
            down = a + int(np.argmax(contacts[a:, foot]))  # its touch-down frame
            if label == "forward":
                moved = np.linalg.norm(ankles[down, foot, :2] - ankles[a - 1, foot, :2])
                assert moved < 0.1, f"{name}: march {a} moves the foot {moved:.3f} m"
                continue
            side_bouts[label] += 1
            right = hips[a, 1, :2] - hips[a, 0, :2]  # the body's right, from the hip line
            right /= np.linalg.norm(right)
            sideways = float((ankles[down, foot, :2] - ankles[a - 1, foot, :2]) @ right)
            assert foot == (1 if label == "right" else 0), f"{name}: {label} bout {a} opens with foot {foot}"
            want = 1.0 if label == "right" else -1.0
            assert sideways * want > 0.05, f"{name}: {label} bout {a} moves the foot {sideways:+.3f} m"
    assert min(side_bouts.values()) >= 3, side_bouts


# ---- the checker ---------------------------------------------------------------------------------


def test_the_checker_passes_the_generated_set(
    small_set: list[Path], capsys: pytest.CaptureFixture[str]
) -> None:
    assert check_folder(small_set[0].parent) == []
    assert check_main([str(small_set[0].parent)]) == 0
    assert "2/2 files passed" in capsys.readouterr().out


def _tamper(d: dict[str, np.ndarray], how: str) -> None:
    if how == "labels-shifted":
        d["labels"] = np.roll(d["labels"], 6)
    elif how == "left-right-swapped":
        swapped = d["labels"].copy()
        swapped[d["labels"] == "left"] = "right"
        swapped[d["labels"] == "right"] = "left"
        d["labels"] = swapped
    elif how == "contacts-swapped":
        d["contacts"] = d["contacts"][:, ::-1].copy()
    elif how == "joints-mirrored":
        j = d["joints"].copy()
        j[:, LEFT_JOINTS], j[:, RIGHT_JOINTS] = d["joints"][:, RIGHT_JOINTS], d["joints"][:, LEFT_JOINTS]
        d["joints"] = j
    elif how == "offset":
        d["joints"] = d["joints"] + np.float32(0.03)
    elif how == "partial-nan":
        d["joints"] = d["joints"].copy()
        d["joints"][200, 5, 0] = np.nan
    elif how == "no-drop-outs":
        d["joints"] = np.nan_to_num(d["joints"], nan=0.5)
    elif how == "dtype":
        d["joints"] = d["joints"].astype(np.float64)
    elif how == "shape":
        d["joints"] = d["joints"][:, :, :2]
    elif how == "source":
        d["source"] = np.array("blind3")
    elif how == "missing":
        del d["contacts"]
    else:
        raise AssertionError(how)


@pytest.mark.parametrize(
    ("how", "expected"),
    [
        ("labels-shifted", ["labels differ from regeneration", "does not start at a lift-off"]),
        ("left-right-swapped", ["labels differ from regeneration", "starts with the wrong foot"]),
        ("contacts-swapped", ["contacts differ from regeneration"]),
        ("joints-mirrored", ["noise sd"]),
        ("offset", ["noise sd"]),
        ("partial-nan", ["partially NaN joints"]),
        ("no-drop-outs", ["mask mismatch", "drop-out fraction"]),
        ("dtype", ["joints float64"]),
        ("shape", ["joints float32 (600, 17, 2)"]),
        ("source", ["source"]),
        ("missing", ["keys"]),
    ],
)
def test_the_checker_finds_a_tampered_file(
    small_set: list[Path], tmp_path: Path, how: str, expected: list[str]
) -> None:
    d = arrays(small_set[0])
    _tamper(d, how)
    np.savez(tmp_path / small_set[0].name, **d)
    problems = check_folder(tmp_path)
    assert problems, f"the checker misses a file with tampered {how}"
    for e in expected:
        assert any(p.startswith(small_set[0].name) and e in p for p in problems), (e, problems)


def test_the_checker_finds_an_empty_folder_a_misnamed_file_a_broken_one_and_another_index(
    small_set: list[Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert check_folder(tmp_path) == [f"no blind4_*.npz files in {tmp_path}"]
    assert check_main([str(tmp_path)]) == 2 and capsys.readouterr().err.startswith("error: no blind4_")
    assert check_main([]) == 2 and "usage" in capsys.readouterr().err
    misnamed = tmp_path / f"blind4_{SEED}_first.npz"
    np.savez(misnamed, **arrays(small_set[0]))
    assert any("unexpected file name" in p for p in check_folder(tmp_path))
    misnamed.unlink()
    broken = tmp_path / f"blind4_{SEED}_05.npz"
    broken.write_bytes(b"not a zip")
    assert any("not a readable NPZ" in p for p in check_folder(tmp_path))
    broken.unlink()
    # file 00's arrays under the name of file 01: they are not what the generator makes for index 1
    np.savez(tmp_path / f"blind4_{SEED}_01.npz", **arrays(small_set[0]))
    problems = check_folder(tmp_path)
    assert any("labels differ" in p for p in problems) and any("noise sd" in p for p in problems), problems
    assert check_main([str(tmp_path)]) == 1 and "0/1 files passed" in capsys.readouterr().out


# ---- determinism ---------------------------------------------------------------------------------


def test_two_runs_give_byte_identical_files(small_set: list[Path], tmp_path: Path) -> None:
    again = write_set(tmp_path, 2, SEED, DURATION_S)  # positional: (folder, count, seed, duration_s)
    for a, b in zip(small_set, again, strict=True):
        assert a.name == b.name
        assert a.read_bytes() == b.read_bytes(), "two runs give byte-identical files"


def test_a_sequence_depends_on_seed_and_index_only(small_set: list[Path], tmp_path: Path) -> None:
    # the same sequence whatever the count of its set ...
    (alone,) = write_set(tmp_path, count=1, seed=SEED, duration_s=DURATION_S)
    assert_same_arrays(arrays(alone), arrays(small_set[0]))
    # ... and generated on its own from (seed, index)
    rec = generate(SEED, 1, DURATION_S)
    assert_same_arrays(rec, arrays(small_set[1]))
    # a different index or seed is a different person doing different things
    for seed, idx in ((SEED, 2), (SEED + 1, 1)):
        other = generate(seed, idx, DURATION_S)
        assert not np.allclose(other["joints"], rec["joints"], equal_nan=True), (seed, idx)
        assert not np.array_equal(other["labels"], rec["labels"]), (seed, idx)


def test_sequence_0_of_the_held_out_set_matches_its_fingerprint() -> None:
    d = generate(DEFAULT_SEED, 0, DEFAULT_DURATION_S)
    assert fingerprint(d) == FINGERPRINT_00, "the motion model or its random draws changed"


# ---- refusals ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"count": 0}, "count must be"),
        ({"count": 1001}, "count must be"),
        ({"count": 2.5}, "count must be"),
        ({"count": True}, "count must be"),
        ({"seed": -1}, "seed must be"),
        ({"seed": 1.5}, "seed must be"),
        ({"duration_s": 0.0}, "duration must be"),
        ({"duration_s": 9.9}, "duration must be"),
        ({"duration_s": 3601.0}, "duration must be"),
        ({"duration_s": float("inf")}, "duration must be"),
        ({"duration_s": float("nan")}, "duration must be"),
        ({"duration_s": "60"}, "duration must be"),
    ],
)
def test_write_set_refuses_bad_values_before_writing(
    tmp_path: Path, kwargs: dict[str, object], match: str
) -> None:
    with pytest.raises(InputError, match=match):
        write_set(tmp_path / "set", **kwargs)  # type: ignore[arg-type]
    assert list(tmp_path.iterdir()) == [], "a refused set writes nothing"


def test_write_set_refuses_a_file_for_a_folder(tmp_path: Path) -> None:
    taken = tmp_path / "taken"
    taken.write_text("keep me")
    for out, match in ((taken, "exists and is not a folder"), (taken / "set", "is not a folder")):
        with pytest.raises(InputError, match=match):
            write_set(out, count=1, seed=1, duration_s=10.0)
    with pytest.raises(InputError, match="non-empty path"):
        write_set("", count=1, seed=1, duration_s=10.0)  # type: ignore[arg-type]
    assert taken.read_text() == "keep me" and sorted(tmp_path.iterdir()) == [taken]


# ---- command line --------------------------------------------------------------------------------


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return run_module("pipeline.sim.blind4", *args)


def test_cli_writes_a_set_and_refuses_bad_input_in_one_line(tmp_path: Path) -> None:
    out = tmp_path / "set"
    r = run_cli(str(out), "--count", "2", "--seed", "5", "--duration", "10")
    assert r.returncode == 0 and r.stderr == "", r.stderr
    assert r.stdout.startswith(f"wrote 2 files to {out} in ")
    paths = [out / "blind4_5_00.npz", out / "blind4_5_01.npz"]
    assert sorted(out.iterdir()) == paths
    assert_same_arrays(arrays(paths[1]), generate(5, 1, 10.0))
    bad = tmp_path / "bad"
    r = run_main("pipeline.sim.blind4", str(bad), "--count", "0")  # in-process: the same command line
    assert r.returncode == 2 and r.stdout == "", (r.returncode, r.stdout)
    assert r.stderr.count("\n") == 1 and r.stderr.startswith("error: count must be"), r.stderr
    assert not bad.exists()


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--count", "0"], "count must be"),
        (["--count", "-3"], "count must be"),
        (["--count", "two"], "invalid int value"),
        (["--duration", "0"], "duration must be"),
        (["--duration", "5"], "duration must be"),
        (["--duration", "nan"], "duration must be"),
        (["--seed", "-1"], "seed must be"),
        (["--bogus"], "unrecognized arguments"),
    ],
)
def test_cli_refuses_bad_arguments(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], match: str
) -> None:
    out = tmp_path / "set"
    assert write_main([str(out), *args]) == 2
    cap = capsys.readouterr()
    assert cap.out == ""
    assert cap.err.count("\n") == 1 and cap.err.startswith("error: ") and match in cap.err, cap.err
    assert list(tmp_path.iterdir()) == [], "a refused set writes nothing"


def test_cli_refuses_a_file_as_out_dir_and_a_missing_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    taken = tmp_path / "taken"
    taken.write_text("keep me")
    for out in (taken, taken / "set"):
        assert write_main([str(out), "--count", "1", "--duration", "10"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("error: ") and "is not a folder" in err, err
        assert taken.read_text() == "keep me" and sorted(tmp_path.iterdir()) == [taken]
    assert write_main([]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and "out_dir" in err, err
