"""Runtime fixtures: small copies of the real demo videos, a simulator pipeline, a UDP listener."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from app.core.config import Settings
from pipeline.demo_data import DemoData
from pipeline.runtime import Pipeline, RuntimeConfig, SimWorldFactory, fusion_factory_from_settings

from .live import Listener, shrink_video


@pytest.fixture(scope="session")
def small_videos(demo_data: DemoData, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """cam01..cam03 of the demo at a quarter size; cam03 is short (it ends first when played once)."""
    folder = tmp_path_factory.mktemp("small_videos")
    lengths = {"cam01": 60, "cam02": 60, "cam03": 12}
    return {cam: shrink_video(demo_data.videos[cam], folder / f"{cam}.mp4", n) for cam, n in lengths.items()}


@pytest.fixture()
def listener() -> Iterator[Listener]:
    rx = Listener()
    yield rx
    rx.close()


@pytest.fixture()
def sim_pipeline(base_settings: Settings) -> Iterator[Pipeline]:
    """The real pipeline on the simulator source (30 fps, one bystander)."""
    sim = SimWorldFactory.from_settings(base_settings.sim, base_settings.cave.geometry(), fps=30.0)
    pipeline = Pipeline(RuntimeConfig(target_fps=30.0, heartbeat_s=0.25), None,
                        fusion=fusion_factory_from_settings(base_settings, None), sim_factory=sim)
    yield pipeline
    pipeline.close()
