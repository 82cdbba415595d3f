"""The skeleton NPZ format (SPEC.md, TEAM.md LABELS): optional tags, contacts and source round-trip."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pipeline.errors import InputError
from pipeline.skeleton import SkeletonSequence, load_npz, save_npz


def _joints(t: int) -> np.ndarray:
    return np.random.default_rng(0).normal(size=(t, 17, 3))


def test_optional_arrays_round_trip(tmp_path: Path) -> None:
    contacts = np.array([[True, False], [True, True], [False, True]])
    seq = SkeletonSequence(
        _joints(3), 60.0, ("still", "forward", "ignore"), ("", "march", "march"), contacts, "gait"
    )
    save_npz(tmp_path / "s.npz", seq)
    back = load_npz(tmp_path / "s.npz")
    assert back.labels == seq.labels
    assert back.tags == seq.tags
    assert back.source == "gait"
    assert back.contacts is not None and back.contacts.dtype == np.bool_
    np.testing.assert_array_equal(back.contacts, contacts)
    np.testing.assert_allclose(back.joints_m, seq.joints_m, atol=1e-6)


def test_old_files_without_the_optional_arrays_still_load(tmp_path: Path) -> None:
    np.savez(tmp_path / "old.npz", joints=_joints(4).astype(np.float32), fps=30.0)
    seq = load_npz(tmp_path / "old.npz")
    assert (seq.labels, seq.tags, seq.contacts, seq.source) == (None, None, None, None)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"labels": ("still", "jump", "still")}, r"unknown labels \['jump'\]"),
        ({"labels": ("still",)}, "labels has 1 entries for 3 frames"),
        ({"tags": ("", "")}, "tags has 2 entries for 3 frames"),
        ({"contacts": np.zeros((3, 3), bool)}, r"contacts must be a bool array of shape \(3, 2\)"),
        ({"contacts": np.zeros((3, 2), float)}, "contacts must be a bool array"),
    ],
)
def test_bad_optional_arrays_are_rejected(kwargs: dict, match: str) -> None:
    with pytest.raises(InputError, match=match):
        SkeletonSequence(_joints(3), 30.0, **kwargs)


def test_a_file_with_an_unknown_label_gets_one_clear_error(tmp_path: Path) -> None:
    np.savez(tmp_path / "bad.npz", joints=_joints(2), fps=30.0, labels=np.array(["still", "walk"]))
    with pytest.raises(InputError, match=r"bad.npz: unknown labels \['walk'\]"):
        load_npz(tmp_path / "bad.npz")


def test_labels_saved_as_python_objects_get_a_hint_and_no_unpickling(tmp_path: Path) -> None:
    """Labels taken from a pandas column are saved as an object array: reading it would unpickle
    (run code from the file), so it is refused, with the way to save it instead; a string array of
    the same labels reads."""
    labels = np.array(["still", "forward"], dtype=object)
    np.savez(tmp_path / "obj.npz", joints=_joints(2), fps=30.0, labels=labels)
    with pytest.raises(InputError, match=r"obj.npz: an array holds Python objects.*dtype=str"):
        load_npz(tmp_path / "obj.npz")
    np.savez(tmp_path / "str.npz", joints=_joints(2), fps=30.0, labels=labels.astype(str))
    assert load_npz(tmp_path / "str.npz").labels == ("still", "forward")
