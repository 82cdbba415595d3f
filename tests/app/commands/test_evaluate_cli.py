"""``cavewalk evaluate`` through the real entry point: its report on a labelled routine, the JSON, and
one clear error for each kind of bad input."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from pipeline.recognition.dataset import encode_labels, load_labelled
from pipeline.sim.body import body_from_height
from pipeline.sim.motion import simulate_user
from pipeline.sim.script import MotionScript, Segment
from tests.app.commands.conftest import run_cli


@pytest.fixture(scope="module")
def labelled(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("eval")
    segs = (Segment("still", 2.0), Segment("forward", 3.0), Segment("still", 2.0), Segment("left", 3.0))
    m = simulate_user(MotionScript(segs, start_yaw_deg=30.0), body_from_height(1.7), 30.0, seed=8)
    tags = np.array([""] * len(m), dtype="<U16")
    tags[:60] = "stand"
    a = d / "a.npz"
    np.savez(a, joints=m.joints_m, fps=30.0, labels=np.array(m.labels), tags=tags, source="unit")
    # the same motion without tags or source, with an ignore stretch
    labels = np.array(m.labels, dtype="<U8")
    labels[100:110] = "ignore"
    b = d / "b.npz"
    np.savez(b, joints=m.joints_m, fps=30.0, labels=labels)
    return a, b


def test_evaluate_prints_the_report_and_writes_json(
    labelled: tuple[Path, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    a, b = labelled
    out = tmp_path / "sub" / "report.json"
    assert run_cli(monkeypatch, "evaluate", "--skeletons", str(a), str(b), "--json", str(out)) == 0
    text = capsys.readouterr().out
    for needle in (
        "frame accuracy",
        "macro-F1",
        "precision",
        "truth \\ pred",
        "start latency",
        "stop latency",
        "false movement",
        "false starts (a command with no bout)",
        "stand",
        "(untagged)",
        "a.npz",
        "b.npz",
    ):
        assert needle in text, f"{needle!r} missing from the report:\n{text}"
    rep = json.loads(out.read_text())
    n = len(load_labelled(a))
    ignored = 10
    assert rep["classes"] == ["still", "forward", "left", "right"]
    assert rep["frames"] < 2 * n - ignored, "the time after each true change and ignore frames are left out"
    assert np.asarray(rep["confusion"]).sum() == rep["frames"]
    assert rep["accuracy"] > 0.9 and rep["macro_f1"] > 0.8, "our own simulator, plain routine"
    assert rep["start_latency"]["n"] == 4 and rep["stop_latency"]["n"] == 2
    assert rep["start_latency"]["missed"] == 0 and 0 <= rep["start_latency"]["median_s"] <= 0.5
    tags = {g["name"]: g for g in rep["per_tag"]}
    assert set(tags) == {"stand", "(untagged)"} and tags["stand"]["moving_frames"] == 0
    assert tags["stand"]["false_movement"] == 0.0, "plain standing is never movement"
    parts = ("false_movement_after_bout", "false_movement_before_bout", "false_starts")
    assert sum(rep[k] for k in parts) == pytest.approx(rep["false_movement"]), "the split adds up"
    assert rep["false_starts"] == 0.0, "no command without a bout in a plain routine"
    assert {g["name"] for g in rep["per_source"]} == {"unit", "b"}, "source from the file, else its name"
    assert rep["per_class"]["left"]["support"] > 0 and rep["per_class"]["right"]["support"] == 0
    assert rep["per_class"]["right"]["recall"] is None


def _bad(tmp: Path) -> dict[str, tuple[Path, str]]:
    j = np.zeros((20, 17, 3))
    lab = np.array(["still"] * 20)
    cases: dict[str, tuple[Path, str]] = {}

    def put(name: str, match: str, **arrays: object) -> None:
        p = tmp / f"{name}.npz"
        np.savez(p, **arrays)  # type: ignore[arg-type]
        cases[name] = (p, match)

    put("nolabels", "no 'labels'", joints=j, fps=30.0)
    put("shape", r"\(T, 17, 3\)", joints=np.zeros((20, 16, 3)), fps=30.0, labels=lab)
    put("unknown", "unknown label.*'walk'", joints=j, fps=30.0, labels=np.array(["still"] * 19 + ["walk"]))
    put("length", r"labels must be \(20,\)", joints=j, fps=30.0, labels=lab[:10])
    put("contacts", "contacts must be", joints=j, fps=30.0, labels=lab, contacts=np.zeros((20, 3), bool))
    put("tags", "tags must be", joints=j, fps=30.0, labels=lab, tags=np.zeros(20))
    put("objects", r"Python objects.*dtype=str", joints=j, fps=30.0, labels=lab.astype(object))
    text = tmp / "text.npz"
    text.write_text("joints, fps, labels")
    cases["text"] = (text, "not an NPZ file")
    cases["missing"] = (tmp / "nope.npz", "not found")
    folder = tmp / "takes"
    folder.mkdir()
    cases["folder"] = (folder, r"is a folder, not an NPZ skeleton file \(give its files: .*takes/\*\.npz\)")
    return cases


@pytest.mark.parametrize(
    "case",
    ["nolabels", "shape", "unknown", "length", "contacts", "tags", "objects", "text", "missing", "folder"],
)
def test_bad_input_ends_with_one_error_line(
    case: str,
    labelled: tuple[Path, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    path, match = _bad(tmp_path)[case]
    out = tmp_path / "r.json"
    out.write_text("old")
    code = run_cli(monkeypatch, "evaluate", "--skeletons", str(labelled[0]), str(path), "--json", str(out))
    err = capsys.readouterr().err
    assert code == 2, f"{case}: exit {code}"
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and re.search(match, lines[0]), err
    assert out.read_text() == "old", "a rejected input leaves the old report as it was"


def test_encode_labels_maps_ignore() -> None:
    assert encode_labels(["still", "forward", "left", "right", "ignore"]).tolist() == [0, 1, 2, 3, -1]
