"""`cavewalk export` through the real entry point on a real take folder: the TRC read back the way
Pose2Sim reads it (``Pose2Sim.common.read_trc``: pandas, tab-separated, 4 header rows skipped),
the labels table, the zip; and damaged takes and bad invocations refused with nothing written."""

from __future__ import annotations

import csv
import io
import json
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pipeline.takes.export import TRC_MARKERS
from tests.app.takes_fixture import FPS, FRAMES_N, NAVIGATOR, OTHER, joints_of, make_take, snapshot
from tests.app.test_cli_errors import run_cli


@pytest.fixture()
def take(tmp_path: Path) -> Path:
    folder = tmp_path / "tiny-take"
    make_take(folder)
    return folder


def read_trc_like_pose2sim(path: Path) -> tuple[list[str], pd.DataFrame, list[str]]:
    """Pose2Sim.common.read_trc's parsing (0.10.49): markers from header row 4, data after row 4."""
    with path.open() as f:
        header = [next(f) for _ in range(5)]
    markers = [m.strip() for m in header[3].split("\t")[2::3] if m.strip()]
    df = pd.read_csv(path, sep="\t", skiprows=4, encoding="utf-8")
    return markers, df, header


def test_trc_is_pose2sims_layout_in_metres_y_up(
    take: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "nav.trc"
    assert run_cli(["export", str(take), "--out", str(out)], monkeypatch) == 0, capsys.readouterr().err
    markers, df, header = read_trc_like_pose2sim(out)
    assert header[0].split("\t")[:3] == ["PathFileType", "4", "(X/Y/Z)"]
    assert header[0].rstrip("\n").endswith(f"tiny-take_P{NAVIGATOR}.trc")
    fields = dict(zip(header[1].split(), header[2].split(), strict=True))
    assert fields["DataRate"] == fields["CameraRate"] == f"{FPS:g}" and fields["Units"] == "m"
    assert int(fields["NumFrames"]) == FRAMES_N and int(fields["NumMarkers"]) == 17
    assert markers == list(TRC_MARKERS)
    frames = df.iloc[:, 0].to_numpy()
    times = df.iloc[:, 1].to_numpy()
    data = df.drop(df.columns[[0, 1]], axis=1)
    data = data.loc[:, ~data.columns.str.startswith("Unnamed")].to_numpy(dtype=float)
    assert data.shape == (FRAMES_N, 17 * 3)
    assert frames.tolist() == list(range(1, FRAMES_N + 1))
    np.testing.assert_allclose(times, np.arange(FRAMES_N) / FPS, atol=1e-5)
    for k in (0, 7, FRAMES_N - 1):
        cave = joints_of(NAVIGATOR, k)  # x right, y front, z up
        expected = cave[:, [1, 2, 0]].reshape(-1)  # Y-up: X = front, Y = up, Z = right
        np.testing.assert_allclose(data[k], expected, atol=2e-5, err_msg=f"frame {k}")
    assert np.isnan(data[4, :3]).all() and np.isfinite(data[4, 3:]).all(), "the unknown nose is empty"
    # another person by user id
    other = tmp_path / "other.trc"
    assert run_cli(["export", str(take), "--out", str(other), "--user", str(OTHER)], monkeypatch) == 0
    data5 = read_trc_like_pose2sim(other)[1].to_numpy()[:, 2 : 2 + 51].astype(float)
    np.testing.assert_allclose(data5[3], joints_of(OTHER, 3)[:, [1, 2, 0]].reshape(-1), atol=2e-5)


def test_labels_table_has_one_row_per_frame_and_person_for_r_and_spss(
    take: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "labels.csv"
    assert run_cli(["export", str(take), "--out", str(out)], monkeypatch) == 0
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    assert len(rows) == FRAMES_N, "the protocol labels the navigator only (user_id empty in the spans)"
    assert {r["user_id"] for r in rows} == {str(NAVIGATOR)} and {r["participant_code"] for r in rows} == {
        "T01"
    }
    by_t = {round(float(r["t_s"]), 3): r for r in rows}
    assert by_t[0.0]["label"] == "still" and by_t[0.0]["label_source"] == "protocol"
    assert by_t[0.5]["label"] == "ignore", "the 0.1 s reaction margin after still -> forward"
    assert by_t[0.65]["label"] == "forward" and by_t[0.65]["predicted"] == "forward"
    assert by_t[0.65]["navigator"] == "1" and by_t[0.65]["predicted_confidence"] == "0.9000"
    assert [r["frame"] for r in rows] == [str(100 + k) for k in range(FRAMES_N)]


def test_zip_holds_the_takes_files_byte_for_byte_and_the_derived_exports(
    take: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "take.zip"
    before = snapshot(take)
    assert run_cli(["export", str(take), "--out", str(out)], monkeypatch) == 0
    with zipfile.ZipFile(out) as zf:
        names = set(zf.namelist())
        manifest = json.loads(zf.read("tiny-take/take.json"))
        for name in manifest["files"]:
            assert zf.read(f"tiny-take/{name}") == (take / name).read_bytes(), name
    assert {f"tiny-take/{n}" for n in ("take.json", "skeletons.npz", "frames.jsonl", "labels.csv")} <= names
    assert {f"tiny-take/trc/tiny-take_P{u}.trc" for u in (NAVIGATOR, OTHER)} <= names
    assert "tiny-take/labels_frames.csv" in names
    assert snapshot(take) == before, "exporting changes nothing in the take"
    folder = tmp_path / "as-folder"
    assert run_cli(["export", str(take), "--out", str(folder), "--format", "folder"], monkeypatch) == 0
    assert (folder / "skeletons.npz").read_bytes() == (take / "skeletons.npz").read_bytes()
    assert (folder / "trc" / f"tiny-take_P{NAVIGATOR}.trc").is_file()


def _damage(take: Path, how: str) -> None:
    if how == "missing":
        (take / "frames.jsonl").unlink()
    elif how == "changed":
        with (take / "skeletons.npz").open("ab") as f:
            f.write(b"x")
    elif how == "recording":
        m = json.loads((take / "take.json").read_text())
        (take / "take.json").write_text(json.dumps({**m, "status": "recording"}))
    elif how == "unlabelled":
        (take / "labels.csv").unlink()
        m = json.loads((take / "take.json").read_text())
        m["files"].pop("labels.csv")
        (take / "take.json").write_text(json.dumps(m))
    elif how == "no-manifest":
        (take / "take.json").unlink()


@pytest.mark.parametrize(
    ("how", "args", "match"),
    [
        ("missing", [], "is damaged: frames.jsonl is missing; nothing was exported"),
        ("changed", ["--format", "trc"], "skeletons.npz does not match its sha256"),
        ("recording", [], "is still recording"),
        ("unlabelled", ["--format", "labels"], "has no labels"),
        ("no-manifest", [], "not a take folder (no take.json)"),
        ("", ["--format", "trc", "--user", "99"], "has no user 99; it has [3, 5]"),
        ("", ["--format", "gif"], "--format must be one of"),
        ("", ["--format", "zip", "--user", "3"], "--user is for --format trc"),
        ("", ["--out", "EXISTING"], "already exists"),
    ],
)
def test_damaged_takes_and_bad_exports_end_with_one_error_and_write_nothing(
    take: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    how: str,
    args: list[str],
    match: str,
) -> None:
    if how:
        _damage(take, how)
    existing = tmp_path / "existing.zip"
    existing.write_bytes(b"mine")
    out = tmp_path / "out.zip"
    before = snapshot(take)
    args = [str(existing) if a == "EXISTING" else a for a in args]
    code = run_cli(["export", str(take), "--out", str(out), *args], monkeypatch)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err[-1].startswith("error: ") and match in err[-1], err
    assert not out.exists() and existing.read_bytes() == b"mine"
    assert snapshot(take) == before, "a refused export changes nothing"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["existing.zip", "tiny-take"], "no partial file"
