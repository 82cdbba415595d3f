"""Fixtures of the app tests: a real SQLite file in tmp, the real app, free ports."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
import uvicorn
from fastapi.testclient import TestClient

from app.core.config import Settings, load_settings
from app.main import create_app
from tests.waiting import GENEROUS_S, HTTP_TIMEOUT_S, free_port, wait_until

#: the Host header of Starlette's TestClient (http://testserver), a name no real server has
TESTCLIENT_HOST = "testserver"


def older_database(db: Path) -> Path:
    """At ``db``, a database an older cavewalk left (the first revision) with participant P01 in it."""
    import sqlite3

    from app.db.engine import make_engine
    from app.db.migrate import upgrade

    engine = make_engine(db)
    upgrade(engine, "0001_initial")
    engine.dispose()
    con = sqlite3.connect(db)
    with con:
        con.execute("INSERT INTO participants (code, notes, created_at) VALUES ('P01', '', '2026-12-01')")
    con.close()
    return db


def make_settings(tmp_path: Path, *, viser: bool = False, **server: object) -> Settings:
    """Settings with the database in ``tmp_path``, free ports, and the TestClient's Host allowed."""
    base = load_settings()
    server.setdefault("allowed_hosts", [TESTCLIENT_HOST])
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


class Served:
    """The app served by uvicorn in a thread on a real socket (the simulator started by default)."""

    def __init__(self, settings: Settings, **app_kw: Any) -> None:
        self.settings = settings
        self.base = f"http://127.0.0.1:{settings.server.port}"
        self.app = create_app(settings, **({"autostart": "simulator"} | app_kw))
        config = uvicorn.Config(
            self.app, host="127.0.0.1", port=settings.server.port, log_level="warning", ws="websockets-sansio"
        )
        self.server = uvicorn.Server(config)
        self.thread = threading.Thread(target=self.server.run, daemon=True)

    def __enter__(self) -> Served:
        self.thread.start()

        def started() -> bool:
            if not self.thread.is_alive():
                raise RuntimeError("uvicorn ended before it started (see the log above)")
            return bool(self.server.started)

        wait_until(started, "uvicorn to start (the app's lifespan: migrations, viser, pipeline)", poll_s=0.05)
        return self

    def __exit__(self, *exc: object) -> None:
        self.server.should_exit = True
        self.thread.join(timeout=30)

    def wait_status(
        self, predicate: Callable[[dict[str, Any]], bool], timeout_s: float = GENEROUS_S
    ) -> dict[str, Any]:
        """The first live status that matches (the deadline only ends a hung test, tests/waiting.py)."""

        def matching() -> dict[str, Any] | None:
            status: dict[str, Any] = httpx.get(f"{self.base}/api/v1/status", timeout=HTTP_TIMEOUT_S).json()
            return status if predicate(status) else None

        return wait_until(matching, "a matching status", timeout_s, poll_s=0.2)
