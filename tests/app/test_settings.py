"""The settings embed each stage's own frozen config as its section: one declaration per setting.

Files and ``CAVEWALK_*`` variables written before that keep working (keys that moved are
mapped with a warning that names the new key), every key of the README's example loads,
and a bad value is reported by its key.
"""

from __future__ import annotations

import dataclasses
import re
import tomllib
import warnings
from pathlib import Path
from typing import Any

import pytest

from app.core.config import MOVED_KEYS, Settings, load_settings
from pipeline.calibration.config import CalibrationConfig
from pipeline.emitter.udp import EmitterConfig
from pipeline.errors import ConfigError
from pipeline.pose.config import PoseConfig
from pipeline.recognition.recognizer import DEFAULT_MODEL_PATH, RecognizerConfig
from pipeline.runtime.config import RuntimeConfig
from pipeline.sim.world import SimConfig
from pipeline.tracking.ocsort import OCSortConfig
from pipeline.triangulation.config import NavigatorConfig, ReconstructionConfig, TriangulationParams
from pipeline.triangulation.navigator import NavigatorSelector
from pipeline.triangulation.reconstructor import Reconstructor
from tests.pipeline.triangulation.scene import corner_cameras

ROOT = Path(__file__).resolve().parents[2]
BEFORE = ROOT / "tests" / "data" / "settings_before_issue16.toml"


def value_at(settings: Settings, dotted: str) -> Any:
    node: Any = settings
    for part in dotted.split("."):
        node = getattr(node, part)
    return node


def leaves(data: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in data.items():
        if isinstance(value, dict):
            out |= leaves(value, f"{prefix}{key}.")
        else:
            out[f"{prefix}{key}"] = value
    return out


def same(a: Any, b: Any) -> bool:
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, Path) or isinstance(b, Path):
        return Path(a) == Path(b)
    return bool(a == b)


def test_the_sections_are_the_stages_own_configs() -> None:
    s = load_settings()
    for name, kind in [("pose", PoseConfig), ("tracking", OCSortConfig), ("recognition", RecognizerConfig),
                       ("runtime", RuntimeConfig), ("emitter", EmitterConfig), ("sim", SimConfig),
                       ("calibration", CalibrationConfig), ("triangulation", TriangulationParams),
                       ("navigator", NavigatorConfig)]:
        assert type(getattr(s, name)) is kind, f"settings.{name} is the stage's {kind.__name__} itself"
    assert s.pose == PoseConfig() and s.runtime == RuntimeConfig(), "the defaults are the stage's own"


def test_every_key_of_the_readme_example_loads(tmp_path: Path) -> None:
    readme = (ROOT / "README.md").read_text()
    section = readme[readme.index("## Configuration"):]
    example = re.search(r"```toml\n(.*?)```", section, re.S)
    assert example is not None, "the README's Configuration section has a TOML example"
    cfg = tmp_path / "cavewalk.toml"
    cfg.write_text(example.group(1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the README uses no key that moved
        s = load_settings(cfg)
    data = tomllib.loads(example.group(1))
    cameras = data.pop("cameras")
    assert [(c.name, c.source) for c in s.cameras] == [(c["name"], c["source"]) for c in cameras]
    keys = leaves(data)
    assert len(keys) >= 10, keys
    for key, value in keys.items():
        assert same(value_at(s, key), value), f"{key}: the file says {value!r}, not {value_at(s, key)!r}"


def test_a_settings_file_from_before_keeps_loading_with_every_key() -> None:
    data = tomllib.loads(BEFORE.read_text())
    with pytest.warns(FutureWarning) as caught:
        s = load_settings(BEFORE)
    messages = " ".join(str(w.message) for w in caught)
    for old, value in leaves(data).items():
        new = MOVED_KEYS.get(old, old)
        assert same(value_at(s, new), value), f"{old} -> {new}: {value!r} became {value_at(s, new)!r}"
        if old in MOVED_KEYS:
            assert f"{old} is deprecated: it is now {new}" in messages, f"the warning names {new}"


def test_moved_keys_land_in_their_new_place_with_their_values() -> None:
    with pytest.warns(FutureWarning, match=r"runtime\.group_tolerance_s is deprecated: it is now "
                                           r"runtime\.grouper\.tolerance_s"):
        s = load_settings(runtime={"target_fps": 24.0, "emit_rate_hz": 90.0, "video_pace_fps": 0.0,
                                   "video_loop": False, "group_tolerance_s": 0.03, "group_max_wait_s": 0.01,
                                   "camera_gone_s": 2.5, "camera_retry_s": 0.5,
                                   "osc": ["127.0.0.1:9000", "[::1]:9001"]})
    assert (s.runtime.target_fps, s.emitter.rate_hz, s.runtime.video_pace_fps, s.runtime.video_loop) == (
        24.0, 90.0, 0.0, False)
    g = s.runtime.grouper
    assert (g.tolerance_s, g.max_wait_s, g.gone_after_s) == (0.03, 0.01, 2.5)
    assert s.runtime.camera_retry_s == 0.5
    assert s.emitter.osc_endpoints == [("127.0.0.1", 9000), ("::1", 9001)]


def test_defaults_follow_the_stages_defaults() -> None:
    s = load_settings()
    assert s.runtime.target_fps == 30.0 and s.emitter.rate_hz == 60.0 and s.emitter.heartbeat_s == 1.0
    assert s.runtime.video_pace_fps is None and s.runtime.video_loop is True


def test_an_old_key_and_its_new_one_together_are_an_error() -> None:
    with pytest.raises(ConfigError, match=r"runtime\.osc and emitter\.osc are the same setting"):
        load_settings(runtime={"osc": ["a:1"]}, emitter={"osc": ["b:2"]})


def test_environment_variables_reach_the_sections(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CAVEWALK_POSE__PROVIDERS", '["cpu"]')
    monkeypatch.setenv("CAVEWALK_POSE__ROI_LONG_SIDE", "256")
    monkeypatch.setenv("CAVEWALK_EMITTER__OSC", '["127.0.0.1:9000"]')
    monkeypatch.setenv("CAVEWALK_RUNTIME__GROUPER__MAX_WAIT_S", "0.03")
    monkeypatch.setenv("CAVEWALK_RUNTIME__CAMERA_GONE_S", "3.0")  # an old key, still read
    with pytest.warns(FutureWarning, match="runtime.grouper.gone_after_s"):
        s = load_settings()
    assert s.pose.providers == ("cpu",) and s.pose.roi_long_side == 256
    assert s.emitter.osc == ("127.0.0.1:9000",)
    assert s.runtime.grouper.max_wait_s == 0.03 and s.runtime.grouper.gone_after_s == 3.0


@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        ({"pose": {"roi_marginn": 1}}, r"pose\.roi_marginn"),
        ({"pose": {"input_long_side": 100}}, r"pose\.input_long_side: must be a positive multiple of 32"),
        ({"runtime": {"grouper": {"tolerance_s": -1}}}, r"runtime\.grouper\.tolerance_s"),
        ({"runtime": {"grouper": {"bogus": 1}}}, r"runtime\.grouper\.bogus"),
        ({"triangulation": {"memory_s": -1}}, r"triangulation\.memory_s \(now association\.memory_s\)"),
        ({"triangulation": {"bogus": 1}}, r"triangulation\.bogus"),
        ({"recognition": {"ema_alpha": 2}}, r"recognition\.ema_alpha"),
        ({"emitter": {"osc": ["nowhere"]}}, r"emitter\.osc: 'nowhere' must be HOST:PORT"),
        ({"planner": {"faults": {}}}, r"planner\.faults is not a setting of its own"),
    ],
)
def test_a_bad_value_is_reported_by_its_key(overrides: dict[str, Any], match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        load_settings(**overrides)


def test_settings_reject_a_bad_osc_destination_by_name() -> None:
    with pytest.raises(ConfigError, match=r"runtime\.osc"), pytest.warns(FutureWarning):
        load_settings(runtime={"osc": ["nowhere"]})


def test_the_reconstructor_gets_its_three_sections() -> None:
    with pytest.warns(FutureWarning):
        s = load_settings(triangulation={"outlier_ratio": 4.0, "smoothing": "none", "memory_s": 9.0})
    cfg = ReconstructionConfig(s.triangulation, s.association, s.tracks3d)
    assert cfg.triangulation.outlier_ratio == 4.0
    assert cfg.tracks.smoothing == "none" and cfg.association.memory_s == 9.0
    cams = corner_cameras()
    rec = Reconstructor(cams, cfg)
    assert rec.config == cfg and rec.rig.names == tuple(c.name for c in cams)


def test_the_navigator_selector_gets_its_section() -> None:
    sel = NavigatorSelector(load_settings(navigator={"dwell_s": 0.0}).navigator)
    assert sel.config.dwell_s == 0.0 and sel.mode == "auto"


def test_calibration_section_is_the_stage_config() -> None:
    cfg = load_settings().calibration
    assert isinstance(cfg, CalibrationConfig)
    assert cfg.dictionary == "DICT_4X4_250" and cfg.grid == (6, 5)


def test_recognition_section_is_the_recognizer_config() -> None:
    with pytest.warns(FutureWarning, match="recognition.speed.forward_step_m"):
        s = load_settings(recognition={"ema_alpha": 0.4, "min_dwell_s": 0.2, "forward_step_m": 0.5})
    cfg = s.recognition
    assert isinstance(cfg, RecognizerConfig)
    assert (cfg.ema_alpha, cfg.min_dwell_s, cfg.speed.forward_step_m) == (0.4, 0.2, 0.5)
    assert cfg.model_path == DEFAULT_MODEL_PATH


def test_the_planner_uses_the_simulators_noise_and_the_pipelines_triangulation() -> None:
    with pytest.warns(FutureWarning):
        s = load_settings(sim={"pixel_noise_px": 4.0}, triangulation={"min_score": 0.4})
    assert s.planner.faults == s.sim.faults and s.planner.faults.pixel_noise_px == 4.0
    assert s.planner.triangulation == s.triangulation
    assert "faults" not in s.dump()["planner"], "config show shows each key once"


def test_config_show_output_loads_back(tmp_path: Path) -> None:
    import tomli_w

    cfg = tmp_path / "shown.toml"
    cfg.write_text(tomli_w.dumps(load_settings().dump()))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        again = load_settings(cfg)
    assert again.dump() == load_settings().dump()


@pytest.mark.parametrize(("precision", "file"), [
    ("fp32", "yolo11n-pose.onnx"), ("int8", "yolo11n-pose.int8.onnx")])
def test_precision_picks_the_model_file(precision: str, file: str, tmp_path: Path) -> None:
    s = Settings.model_validate({"paths": {"models_dir": str(tmp_path)}, "pose": {"precision": precision}})
    assert s.pose_model_path == tmp_path / file
    named = Settings.model_validate({"pose": {"precision": precision, "model": str(tmp_path / "x.onnx")}})
    assert named.pose_model_path == tmp_path / "x.onnx", "an explicit model file wins"


def test_unknown_precision_is_rejected() -> None:
    with pytest.raises(ValueError, match="precision"):
        Settings.model_validate({"pose": {"precision": "fp16"}})


def test_a_section_is_frozen() -> None:
    s = load_settings()
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.pose.roi = False  # type: ignore[misc]
