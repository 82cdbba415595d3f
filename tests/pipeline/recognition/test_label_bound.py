"""The fixed-hold oracle of `scripts/label_bound.py` (the ceiling a streaming recogniser can reach on
labels that keep pauses inside a bout), with and without a late view of each lift-off."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

from pipeline.recognition.dataset import LabelledSequence

ROOT = Path(__file__).resolve().parents[3]
SCRIPT = ROOT / "scripts" / "label_bound.py"
sys.path.insert(0, str(ROOT / "scripts"))

import label_bound  # noqa: E402

FPS = 30.0
F = 1  # forward


def _bout(pause_s: float) -> LabelledSequence:
    """6 s: standing, then a march of 6 steps (0.3 s swings, ``pause_s`` both feet down between
    them) labelled forward from the first lift-off to the last touch-down, then standing."""
    n = round(6.0 * FPS)
    contacts = np.ones((n, 2), dtype=bool)
    labels = np.zeros(n, dtype=np.int64)
    t = 1.0
    for k in range(6):
        a, b = round(t * FPS), round((t + 0.3) * FPS)
        contacts[a:b, k % 2] = False
        t += 0.3 + pause_s
    first, last = round(1.0 * FPS), round((t - pause_s) * FPS)
    labels[first:last] = F
    return LabelledSequence(np.zeros((n, 17, 3)), FPS, labels, np.full(n, "", dtype=str), contacts)


def test_a_hold_longer_than_the_pause_holds_the_bout_unless_the_lift_off_is_seen_late() -> None:
    seq = _bout(0.35)
    inside = seq.labels == F
    first = int(np.flatnonzero(inside)[0])
    on_time = label_bound.oracle(seq, 0.4)
    assert (on_time[first + 1 :][inside[first + 1 :]] == F).all(), "0.35 s pauses held by a 0.4 s hold"
    late = label_bound.oracle(seq, 0.4, lag_s=0.1)  # each pause looks 0.45 s long
    assert int(np.flatnonzero(late == F)[0]) == first + 3, "the command starts 0.1 s late"
    held = late[first + 3 :][inside[first + 3 :]] == F
    breaks = int(np.sum(held[:-1] & ~held[1:]))
    assert breaks == 5, f"the bout breaks in each of its 5 pauses, not {breaks}"
    assert (label_bound.oracle(seq, 0.5, lag_s=0.1)[first + 4 :][inside[first + 4 :]] == F).all()


def test_a_swing_shorter_than_the_lag_is_never_seen() -> None:
    contacts = np.ones((20, 2), dtype=bool)
    contacts[2:4, 0] = False  # 2 frames up
    contacts[8:15, 1] = False  # 7 frames up
    seen = label_bound.seen_swings(contacts, 3)
    assert not seen[:, 0].any()
    assert np.flatnonzero(seen[:, 1]).tolist() == list(range(11, 15))


def test_bad_arguments_are_one_error_line(tmp_path: Path) -> None:
    for args in (["--lag", "-0.1"], ["--hold", "nan"]):
        done = subprocess.run(
            [sys.executable, str(SCRIPT), str(tmp_path), *args], capture_output=True, text=True, check=False
        )
        assert done.returncode == 2 and done.stderr.startswith("error: --hold and --lag"), done.stderr
    done = subprocess.run(
        [sys.executable, str(SCRIPT), str(tmp_path / "none")], capture_output=True, text=True, check=False
    )
    assert done.returncode == 2 and done.stderr.strip() == f"error: {tmp_path / 'none'} is not a folder"


def test_a_swing_the_ankle_never_shows_is_contact_for_the_visible_oracle() -> None:
    """--visible: a foot flagged up while its ankle stays where it was (a generator's unloaded foot)
    is contact; a 5 cm lift under 1.2 cm of capture noise stays a swing."""
    rng = np.random.default_rng(3)
    n = 60
    joints = np.zeros((n, 17, 3))
    joints[:, label_bound._ANKLES[0]] = [-0.1, 0.0, 0.08]
    joints[:, label_bound._ANKLES[1]] = [0.1, 0.0, 0.08]
    joints[10:25, label_bound._ANKLES[0], 2] += 0.05 * np.sin(np.linspace(0, np.pi, 15))  # a real lift
    joints += rng.normal(0.0, 0.012, joints.shape)
    joints[40, label_bound._ANKLES[1]] = np.nan  # an unknown frame inside the unseen swing
    contacts = np.ones((n, 2), dtype=bool)
    contacts[10:25, 0] = False
    contacts[35:50, 1] = False  # flagged up, never moves
    seen = label_bound.visible_contacts(joints, contacts, 0.03)
    assert np.array_equal(seen[:, 0], contacts[:, 0]), "the 5 cm lift is a swing"
    assert seen[:, 1].all(), "the unmoved foot is contact"
    assert np.array_equal(label_bound.visible_contacts(joints, contacts, 0.5)[:, 0], np.ones(n, bool))


def test_a_bad_visible_distance_is_one_error_line(tmp_path: Path) -> None:
    for value in ("0", "-0.02", "nan", "0.8"):
        done = subprocess.run(
            [sys.executable, str(SCRIPT), str(tmp_path), "--visible", value],
            capture_output=True, text=True, check=False,
        )  # fmt: skip
        assert done.returncode == 2 and done.stderr.startswith("error: --visible is metres"), done.stderr
