"""RuntimeConfig from the settings' runtime section, and its checks."""

from __future__ import annotations

from typing import Any

import pytest

from app.core.config import Settings
from pipeline.runtime import RuntimeConfig


def test_from_settings_maps_the_runtime_section(base_settings: Settings) -> None:
    runtime = base_settings.runtime.model_copy(update={
        "target_fps": 24.0, "emit_rate_hz": 90.0, "video_pace_fps": 0.0, "video_loop": False,
        "group_tolerance_s": 0.03, "group_max_wait_s": 0.01, "camera_gone_s": 2.5, "camera_retry_s": 0.5,
        "osc": ["127.0.0.1:9000", "[::1]:9001"],
    })
    config = RuntimeConfig.from_settings(runtime)
    assert (config.target_fps, config.emit_rate_hz, config.video_pace_fps, config.video_loop) == (
        24.0, 90.0, 0.0, False)
    assert (config.grouper.tolerance_s, config.grouper.max_wait_s, config.grouper.gone_after_s) == (
        0.03, 0.01, 2.5)
    assert config.camera_retry_s == 0.5
    assert config.osc == (("127.0.0.1", 9000), ("::1", 9001))


def test_defaults_follow_the_settings_defaults(base_settings: Settings) -> None:
    config = RuntimeConfig.from_settings(type(base_settings.runtime)())
    assert config.target_fps == 30.0 and config.emit_rate_hz == 60.0 and config.heartbeat_s == 1.0
    assert config.video_pace_fps is None and config.video_loop is True


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"target_fps": 0.0}, "target_fps"),
        ({"video_pace_fps": -1.0}, "video_pace_fps"),
        ({"ring_slots": 1}, "ring_slots"),
        ({"start_method": "thread"}, "start_method"),
    ],
)
def test_bad_values_rejected(kwargs: dict[str, Any], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        RuntimeConfig(**kwargs)


def test_bad_osc_destination_rejected(base_settings: Settings) -> None:
    runtime = base_settings.runtime.model_copy(update={"osc": ["no-port"]})
    with pytest.raises(ValueError, match="must be HOST:PORT"):
        RuntimeConfig.from_settings(runtime)


def test_settings_reject_a_bad_osc_destination_by_name() -> None:
    from app.core.config import load_settings
    from pipeline.errors import ConfigError

    with pytest.raises(ConfigError, match=r"runtime\.osc"):
        load_settings(runtime={"osc": ["nowhere"]})
