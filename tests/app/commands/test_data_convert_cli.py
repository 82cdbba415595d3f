"""``cavewalk data convert`` through the real entry point: a real BVH take (CMU 131_02, committed
under pipeline/mocap/vendored/) becomes a labelled skeleton NPZ that ``cavewalk evaluate`` scores;
bad input is one error line and writes nothing."""

from __future__ import annotations

import gzip
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pipeline.mocap.fetch import (
    FILES_URL,
    PACKAGES,
    download,
    fetch_mocap,
    mocap_dir,
    read_members,
    vendored_dir,
)
from pipeline.skeleton import J, load_npz
from tests.app.commands.conftest import run_cli
from tests.pipeline.mocap.test_mocap_readers import write_c3d


@pytest.fixture
def take(tmp_path: Path) -> Path:
    """CMU 131_02 ("Start Walk Stop") as the BVH file a lab would export."""
    gz = vendored_dir(PACKAGES["bvh11"]) / "resources" / "131_02.bvh.gz"
    path = tmp_path / "walk.bvh"
    path.write_bytes(gzip.decompress(gz.read_bytes()))
    return path


def test_a_bvh_take_becomes_a_labelled_npz_that_evaluate_scores(
    take: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "npz"
    args = ("data", "convert", str(take), "--out", str(out), "--bout", "forward", "--tag", "walk")
    assert run_cli(monkeypatch, *args, "--height-m", "1.84") == 0
    printed = capsys.readouterr().out
    assert re.search(r"walk\.npz: 312 frames at 30 fps, still 1\.\d s, forward 9\.\d s", printed), printed
    seq = load_npz(out / "walk.npz")
    labels = np.asarray(seq.labels)
    assert seq.fps == 30.0 and seq.source == "walk" and seq.contacts is not None
    assert labels[0] == labels[-1] == "still" and 250 < np.sum(labels == "forward") < 290
    assert set(np.asarray(seq.tags)[labels == "forward"]) == {"walk"}
    assert 1.66 < np.percentile(seq.joints_m[:, J["nose"], 2], 90) < 1.84, "scaled to the height given"
    assert run_cli(monkeypatch, "evaluate", "--skeletons", str(out / "walk.npz")) == 0
    assert re.search(r"frame accuracy \d+\.\d+ %", capsys.readouterr().out)
    # one label for the whole clip, as asked (a clip that is all walking, say): every frame
    one = ("data", "convert", str(take), "--out", str(tmp_path / "one"), "--label", "forward")
    assert run_cli(monkeypatch, *one) == 0
    assert set(load_npz(tmp_path / "one" / "walk.npz").labels or ()) == {"forward"}
    assert "walk.npz: 312 frames at 30 fps, forward 10.4 s" in capsys.readouterr().out
    # without a label option: joints only, for cavewalk recognize
    assert run_cli(monkeypatch, "data", "convert", str(take), "--out", str(tmp_path / "plain")) == 0
    assert load_npz(tmp_path / "plain" / "walk.npz").labels is None


def test_a_plug_in_gait_c3d_trial_becomes_the_same_npz_as_the_catalogue_s(
    base_settings: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A real Vicon trial with Plug-in Gait's joint centres (pyc3dsample's ``testsample.c3d``, from the
    pinned sdist the catalogue reads): ``data convert --bout forward`` writes what the catalogue's
    clip ``pyc3dsample-walk-1`` holds, joint for joint and label for label."""
    cache = base_settings.paths.cache_dir
    catalogue = {p.stem: p for p in fetch_mocap(cache)}
    pkg = PACKAGES["pyc3dsample"]
    archive = download(pkg, mocap_dir(cache) / "downloads", FILES_URL, print)
    trial = tmp_path / "testsample.c3d"
    trial.write_bytes(read_members(archive, pkg, ["data/testsample.c3d"])["data/testsample.c3d"])
    out = tmp_path / "npz"
    args = ("data", "convert", str(trial), "--out", str(out), "--bout", "forward", "--tag", "walk")
    assert run_cli(monkeypatch, *args) == 0
    assert re.search(r"testsample\.npz: \d+ frames at 30 fps, .*forward", capsys.readouterr().out)
    mine, theirs = load_npz(out / "testsample.npz"), load_npz(catalogue["pyc3dsample-walk-1"])
    np.testing.assert_array_equal(mine.joints_m, theirs.joints_m)
    assert mine.labels == theirs.labels and "forward" in (mine.labels or ())


def _bad_cases(take: Path, tmp: Path) -> dict[str, tuple[list[str], str]]:
    (tmp / "junk.bvh").write_text("not a skeleton")
    (tmp / "a").mkdir()
    twin = tmp / "a" / "walk.bvh"
    twin.write_bytes(take.read_bytes())
    (tmp / "file").write_text("x")
    (tmp / "junk.c3d").write_text("not a c3d file" * 100)
    markers = tmp / "markers.c3d"  # markers a lab exported without running a model: no joints
    markers.write_bytes(write_c3d(["LASI", "RASI", "LKNE"], np.ones((4, 3, 3)), 100.0, True, set()))
    t = str(take)
    return {
        "unknown label": ([t, "--label", "jump"], r"--label must be one of still, forward, left, right"),
        "both": ([t, "--label", "still", "--bout", "forward"], "give --label or --bout, not both"),
        "bout still": ([t, "--bout", "still"], "--bout must be forward, left or right"),
        "tag alone": ([t, "--tag", "walk"], "--tag names what the person does"),
        "npz": ([str(tmp / "x.npz")], r"cannot convert a \.npz file"),
        "amc alone": ([str(tmp / "x.amc")], "an AMC motion needs its ASF skeleton"),
        "missing": ([str(tmp / "gone.bvh")], "BVH file not found"),
        "junk": ([t, str(tmp / "junk.bvh")], "not a BVH file"),
        "twins": ([t, str(twin)], "share a name"),
        "height": ([t, "--height-m", "3"], r"height_m must be in \(0\.5, 2\.5\)"),
        "asf for bvh": ([t, "--skeleton", str(tmp / "file")], "carries its own skeleton"),
        "height for amc": ([str(tmp / "x.amc"), "--skeleton", str(tmp / "file"), "--height-m", "1.8"],
                           "keeps its own units; --height-m is for BVH files"),
        "c3d markers only": ([str(markers)], r"no joint centres.*LFEP.*has 3 points"),
        "c3d not c3d": ([str(tmp / "junk.c3d")], "not a C3D file"),
    }


@pytest.mark.parametrize(
    "case",
    ["unknown label", "both", "bout still", "tag alone", "npz", "amc alone", "missing", "junk", "twins",
     "height", "asf for bvh", "height for amc", "c3d markers only", "c3d not c3d", "out is a file", "exists"],
)  # fmt: skip
def test_bad_input_is_one_error_line_and_writes_nothing(
    case: str, take: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "npz"
    if case == "exists":
        out.mkdir()
        (out / "walk.npz").write_bytes(b"earlier work")
        args, match = [str(take)], "walk.npz exists; remove it or give another --out"
    elif case == "out is a file":
        out.write_text("x")
        args, match = [str(take)], "is a file, not a folder"
    else:
        args, match = _bad_cases(take, tmp_path)[case]
    before = sorted(p.name for p in out.iterdir()) if out.is_dir() else None
    code = run_cli(monkeypatch, "data", "convert", *args, "--out", str(out))
    err = [x for x in capsys.readouterr().err.splitlines() if x.strip()]
    assert code == 2 and len(err) == 1 and err[0].startswith("error: ") and re.search(match, err[0]), err
    after = sorted(p.name for p in out.iterdir()) if out.is_dir() else None
    assert after == before, "nothing written"
    if case == "exists":
        assert (out / "walk.npz").read_bytes() == b"earlier work"
