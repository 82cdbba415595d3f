"""Runtime fixtures: small copies of the real demo videos, a simulator pipeline, a UDP listener."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from pipeline.cave import box_cave
from pipeline.demo_data import DemoData
from pipeline.emitter.udp import EmitterConfig
from pipeline.runtime.chain import SimWorldFactory
from pipeline.runtime.config import RuntimeConfig
from pipeline.runtime.pipeline import Pipeline
from pipeline.runtime.shm import FrameRing
from pipeline.sim.world import SimConfig

from .live import CreatedRings, Listener, shrink_video


@pytest.fixture(scope="session")
def small_videos(demo_data: DemoData, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """cam01..cam03 of the demo at a quarter size; cam03 is short (it ends first when played once)."""
    folder = tmp_path_factory.mktemp("small_videos")
    lengths = {"cam01": 60, "cam02": 60, "cam03": 12}
    return {cam: shrink_video(demo_data.videos[cam], folder / f"{cam}.mp4", n) for cam, n in lengths.items()}


@pytest.fixture()
def created_rings(monkeypatch: pytest.MonkeyPatch) -> CreatedRings:
    """Every ring this test's pipelines create, by name (``live.CreatedRings``)."""
    rings = CreatedRings()
    monkeypatch.setattr(FrameRing, "create", rings.spy(FrameRing.create))
    return rings


@pytest.fixture()
def listener() -> Iterator[Listener]:
    rx = Listener()
    yield rx
    rx.close()


@pytest.fixture()
def sim_pipeline() -> Iterator[Pipeline]:
    """The real pipeline on the simulator source (30 fps, one bystander)."""
    sim = SimWorldFactory.build(SimConfig(fps=30.0), box_cave())
    pipeline = Pipeline(RuntimeConfig(target_fps=30.0), None, simulator=sim,
                        emitter=EmitterConfig(heartbeat_s=0.25))
    yield pipeline
    pipeline.close()
