"""Fixtures of the app tests: a real SQLite file in tmp, the real app, free ports."""

from __future__ import annotations

import socket
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from app.core.config import Settings, load_settings
from app.main import create_app


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def make_settings(tmp_path: Path, *, viser: bool = False, **server: object) -> Settings:
    base = load_settings()
    return base.model_copy(
        update={
            "paths": base.paths.model_copy(update={"db": tmp_path / "cavewalk.db"}),
            "server": base.server.model_copy(
                update={"viser": viser, "viser_port": free_port(), "port": free_port(), **server}
            ),
        }
    )


@pytest.fixture()
def app_settings(tmp_path: Path) -> Settings:
    """Settings with the database in tmp_path and no 3D view (fast)."""
    return make_settings(tmp_path)


@pytest.fixture()
def client(app_settings: Settings) -> Iterator[TestClient]:
    """The app without a pipeline, started (lifespan run) and talking to a real SQLite file."""
    with TestClient(create_app(app_settings, pipeline_factory=None)) as c:
        yield c
