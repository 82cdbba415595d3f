"""Shared fixtures: the real demo data and pose model come through the same code users run."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from app.core.config import Settings, load_settings, set_settings
from pipeline.demo_data import DemoData, fetch_demo
from pipeline.pose.prepare import prepare_pose_model
from tests.disk import holding_the_disk

ARTIFACTS = Path(__file__).resolve().parent.parent / "test-artifacts"

# The suite runs on the default settings, not on what `cavewalk tune` chose for this machine (a file
# that may or may not exist in the user's config directory), and `cavewalk demo`/`serve` do not tune
# on their first start here; tests/pipeline/pose/test_tune.py sets both itself.
os.environ.setdefault("CAVEWALK_TUNE_FILE", str(Path(tempfile.gettempdir()) / "cavewalk-tests-no-tuned.toml"))
os.environ.setdefault("CAVEWALK_TUNE__ON_FIRST_START", "false")


@pytest.fixture(scope="session")
def base_settings() -> Settings:
    """The default settings (models and data in the user cache, as `cavewalk` uses them)."""
    return load_settings()


@pytest.fixture(scope="session")
def demo_data(base_settings: Settings) -> DemoData:
    """Pose2Sim's Demo_SinglePerson, fetched like `cavewalk data demo` does."""
    return fetch_demo(base_settings.paths.cache_dir)


@pytest.fixture(scope="session")
def pose_model_path(base_settings: Settings) -> Path:
    """The ONNX pose model, prepared like `cavewalk models prepare` does."""
    return prepare_pose_model(base_settings.paths.models_dir).path


@pytest.fixture()
def isolated_settings(tmp_path: Path) -> Iterator[Settings]:
    """Settings whose database and cache live in tmp_path; installed process-wide for the test."""
    base = load_settings()
    settings = base.model_copy(
        update={"paths": base.paths.model_copy(update={"db": tmp_path / "cavewalk.db"})}
    )
    set_settings(settings)
    yield settings
    set_settings(None)


@pytest.fixture(scope="session")
def artifacts_dir() -> Path:
    ARTIFACTS.mkdir(exist_ok=True)
    return ARTIFACTS


@pytest.fixture()
def disk_alone() -> Iterator[None]:
    """No other test that fills the disk runs meanwhile (``tests.disk.holding_the_disk``)."""
    with holding_the_disk():
        yield
