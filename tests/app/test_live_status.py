"""The one typed status and its fan-out (issue 16 item 4): its JSON form is exactly the API's
object; the WebSockets get each pushed status from one feed (composed once for all of them), and
the app's own live facts when they change, with no socket polling."""

from __future__ import annotations

import asyncio
import json
import threading
from pathlib import Path
from typing import Any

import httpx
import pytest
import websockets
from fastapi.testclient import TestClient

from app.schemas.live import (
    ActionPublic,
    CameraStatusPublic,
    CommandPublic,
    GroupPublic,
    LatencyPublic,
    NavigationPublic,
    PersonPublic,
    StatusPublic,
)
from app.services.live import LiveFeed
from pipeline.cave import box_cave
from pipeline.navigation.config import NavigationConfig
from pipeline.runtime.chain import ChainConfig, SimWorldFactory, build_chain
from pipeline.runtime.messages import DetectedFrame
from pipeline.runtime.metrics import RuntimeMetrics
from pipeline.runtime.status import (
    ActionStatus,
    CameraStatus,
    NavigationStatus,
    PipelineStatus,
    Skeleton,
    frame_people,
)
from pipeline.sim.world import SimConfig
from tests.app.conftest import Served, make_settings
from tests.waiting import HTTP_TIMEOUT_S

APP_FIELDS = {"held_by", "running_session_id", "active_calibration_id", "restart_for", "alarm", "storage"}


def group_status() -> PipelineStatus:
    """A status of the simulator's two stepping people in group mode, with everything filled in."""
    sim = SimWorldFactory.build(SimConfig(fps=30.0, people=2, bystanders=0, seed=5), box_cave())
    navigation = NavigationConfig("group")
    chain = build_chain(ChainConfig(navigation=navigation).on_simulator(sim))
    world = sim()
    for i in range(150):
        t = i / 30.0
        result = chain.update(DetectedFrame(i, t, tuple(world.step(timestamp_s=t).views), t, t))
        nav = result.navigation
        if i > 60 and result.action is not None and nav is not None and nav.group is not None and all(
                any(c.user_id == p.user_id for c in nav.commands) for p in result.people3d):
            metrics = RuntimeMetrics()
            metrics.frame(1.0, {"detect": 12.5, "fuse": 3.25}, 0)
            return PipelineStatus(
                "running", "simulator", 29.7, 2, 150, metrics.latency_summary(),
                (CameraStatus("cam01", True, 30.0), CameraStatus("cam02", False, 0.0, "no frame for 1.0 s")),
                frame_people(result), result.navigator, "manual",
                NavigationStatus.of(nav, navigation), ActionStatus.of(result.action),
                tuple(Skeleton.of(p) for p in result.people3d), result.frame_index)
    raise AssertionError("the simulated group never had a command for everyone")


def test_the_status_json_is_exactly_the_api_object() -> None:
    status = group_status()
    message = status.to_json()
    assert set(message) == set(StatusPublic.model_fields) - APP_FIELDS
    assert json.loads(json.dumps(message, allow_nan=False)) == message, "plain JSON values, no NaN"
    for person in message["people"]:
        assert set(person) == set(PersonPublic.model_fields)
        assert person["navigating"] and set(person["command"]) == set(CommandPublic.model_fields)
    assert set(message["action"]) == set(ActionPublic.model_fields)
    assert set(message["navigation"]) == set(NavigationPublic.model_fields)
    assert set(message["navigation"]["group"]) == set(GroupPublic.model_fields)
    assert all(set(c) == set(CameraStatusPublic.model_fields) for c in message["cameras"])
    assert all(set(q) == set(LatencyPublic.model_fields) for q in message["latency_ms"].values())
    assert message["latency_ms"]["detect"]["p50"] == 12.5 and message["latency_ms"]["capture"]["p50"] is None
    for skeleton in message["extra"]["people3d"]:
        assert set(skeleton) == {"user_id", "joints", "reproj_px"} and len(skeleton["joints"]) == 17
    # what GET /status serialises and what the WebSocket sends (the dict itself) are the same
    public = StatusPublic.model_validate(message).model_dump(exclude=APP_FIELDS)
    assert public == message
    stopped = PipelineStatus("stopped").to_json()
    assert StatusPublic.model_validate(stopped).model_dump(exclude=APP_FIELDS) == stopped


def test_the_feed_composes_once_per_change_for_every_socket_and_never_faster_than_its_rate() -> None:
    composed: list[int] = []

    def compose() -> dict[str, Any]:
        composed.append(len(composed) + 1)
        return {"n": len(composed)}

    async def scenario() -> None:
        feed = LiveFeed(compose, rate_hz=0.01)  # a period of 100 s: a second message is never due here
        feed.bind(asyncio.get_running_loop())
        feed.own_clock(False)  # a pipeline publishes
        a, b = feed.subscribe(), feed.subscribe()
        await asyncio.to_thread(feed.publish)  # a status pushed from the pipeline's thread
        first = await asyncio.wait_for(asyncio.gather(a.get(), b.get()), HTTP_TIMEOUT_S)
        assert first == [{"n": 1}, {"n": 1}] and composed == [1], "one message, composed once, for both"
        feed.publish()
        feed.publish()
        for _ in range(5):
            await asyncio.sleep(0)
        assert a.empty() and b.empty() and composed == [1], "within the period nothing more goes out"
        feed.unsubscribe(a)
        feed.unsubscribe(b)

    asyncio.run(scenario())


def test_without_a_pipeline_the_feed_keeps_the_rate_on_its_own_clock() -> None:
    async def scenario() -> None:
        feed = LiveFeed(lambda: {"state": "unavailable"}, rate_hz=50.0)
        feed.bind(asyncio.get_running_loop())
        q = feed.subscribe()
        got = [await asyncio.wait_for(q.get(), HTTP_TIMEOUT_S) for _ in range(3)]
        assert got == [{"state": "unavailable"}] * 3, "the current status, again on the feed's clock"
        feed.unsubscribe(q)

    asyncio.run(scenario())


@pytest.mark.slow
def test_a_socket_gets_the_current_status_at_once_then_the_app_s_changes_pushed(tmp_path: Path) -> None:
    """No pipeline is built (the feed keeps the rate itself): the socket gets the session that starts."""
    with Served(make_settings(tmp_path), pipeline_factory=None, autostart=None) as served:
        base = f"{served.base}/api/v1"
        url = f"ws://127.0.0.1:{served.settings.server.port}/api/v1/ws/live"
        ready = threading.Event()
        received: list[dict[str, Any]] = []

        async def read() -> None:
            async with websockets.connect(url) as ws:
                received.append(json.loads(await asyncio.wait_for(ws.recv(), HTTP_TIMEOUT_S)))
                ready.set()
                while received[-1]["running_session_id"] is None:
                    received.append(json.loads(await asyncio.wait_for(ws.recv(), HTTP_TIMEOUT_S)))

        reader = threading.Thread(target=lambda: asyncio.run(read()))
        reader.start()
        assert ready.wait(HTTP_TIMEOUT_S), "the current status at once"
        assert received[0]["type"] == "status" and received[0]["state"] == "unavailable"
        pid = httpx.post(f"{base}/participants", json={"code": "FEED1"}, timeout=HTTP_TIMEOUT_S).json()["id"]
        sid = httpx.post(f"{base}/sessions", json={"participant_id": pid, "condition": "EC"},
                         timeout=HTTP_TIMEOUT_S).json()["id"]
        assert httpx.post(f"{base}/sessions/{sid}/start", timeout=HTTP_TIMEOUT_S).status_code == 200
        reader.join(HTTP_TIMEOUT_S)
        assert not reader.is_alive() and received[-1]["running_session_id"] == sid


def test_a_restart_before_any_start_is_refused(client: TestClient) -> None:
    """``POST /pipeline/restart`` repeats the last start: with none yet, one 409 that says so."""
    r = client.post("/api/v1/pipeline/restart")
    assert r.status_code == 409 and "has not been started yet" in r.json()["detail"], r.text
    assert client.get("/api/v1/status").json()["restart_for"] == []
