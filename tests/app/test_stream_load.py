"""The locomotion stream under dashboard load (issue 15, load; issue 16 item 3).

The real app (uvicorn on a real socket, the simulator source) is loaded by bounded HTTP and
WebSocket clients in the server's own process, so the web server's interpreter is as busy
as it gets; a real UDP socket receives the stream. Since the stream leaves from the fusion
worker, the load must not thin it. What is asserted does not depend on the test machine's
clock: over a fixed number of locomotion datagrams, ``seq`` has no gap and never goes back
and every datagram comes from one sender; the rate is counted on the sender's own clock
(locomotion datagrams between two heartbeats, whose ``ts`` the emitter stamps when it sends
them) and must be at least half the configured 60 a second (a wide bound: a busy CI machine
must not fail it). The issue's figure (>= 50 a second at the receiver, and the
longest gap) is measured by ``scripts/load_test.py`` (docs/issue15.md).
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
import websockets

from tests.app.conftest import Served, make_settings
from tests.datagrams import DatagramRecorder
from tests.waiting import HTTP_TIMEOUT_S, wait_until

pytestmark = pytest.mark.slow

HTTP_CLIENTS = 30
HTTP_RATE_HZ = 5.0  # per client: bounded, as a dashboard is
WS_CLIENTS = 20
WINDOW = 600  # locomotion datagrams measured under load (about 10 s at 60 a second)
MIN_RATE = 30.0  # half of rate_hz 60 (the figure itself: scripts/load_test.py)


class Load:
    """Bounded HTTP and WebSocket clients against the served app, until :meth:`stop`."""

    def __init__(self, base: str) -> None:
        self.base = base
        self.stop_event = threading.Event()
        self.requests = 0
        self.ws_messages = 0
        self._lock = threading.Lock()
        self._threads = [threading.Thread(target=self._http, daemon=True) for _ in range(HTTP_CLIENTS)]
        self._threads.append(threading.Thread(target=self._ws_all, daemon=True))

    def start(self) -> Load:
        for t in self._threads:
            t.start()
        return self

    def _http(self) -> None:
        with httpx.Client(timeout=HTTP_TIMEOUT_S) as client:
            while not self.stop_event.is_set():
                for path in ("/api/v1/status", "/api/v1/pipeline"):
                    try:
                        client.get(self.base + path)
                    except httpx.HTTPError:
                        continue
                    with self._lock:
                        self.requests += 1
                self.stop_event.wait(2.0 / HTTP_RATE_HZ)

    def _ws_all(self) -> None:
        url = self.base.replace("http://", "ws://") + "/api/v1/ws/live"

        async def one() -> None:
            async with websockets.connect(url, open_timeout=HTTP_TIMEOUT_S) as ws:
                while not self.stop_event.is_set():
                    try:
                        await asyncio.wait_for(ws.recv(), 1.0)
                    except TimeoutError:
                        continue
                    with self._lock:
                        self.ws_messages += 1

        async def every() -> None:
            await asyncio.gather(*(one() for _ in range(WS_CLIENTS)), return_exceptions=True)

        asyncio.run(every())

    def stop(self) -> None:
        self.stop_event.set()
        for t in self._threads:
            t.join(timeout=HTTP_TIMEOUT_S)


@pytest.fixture()
def receiver() -> Iterator[DatagramRecorder]:
    rx = DatagramRecorder()
    yield rx
    rx.close()


def test_the_stream_holds_its_rate_and_order_under_dashboard_load(
    tmp_path: Path, receiver: DatagramRecorder
) -> None:
    base = make_settings(tmp_path)
    settings = base.model_copy(update={"workstations": [f"127.0.0.1:{receiver.port}"]})
    assert settings.emitter.rate_hz == 60.0
    with Served(settings) as served:
        wait_until(lambda: receiver.locomotion_since(0) >= 30, "locomotion from the running simulator")
        load = Load(served.base).start()
        try:
            wait_until(lambda: load.requests >= HTTP_CLIENTS and load.ws_messages >= WS_CLIENTS,
                       "every client under way")
            start = len(receiver.got)
            wait_until(lambda: receiver.locomotion_since(start) >= WINDOW,
                       f"{WINDOW} locomotion datagrams under load")
            window = receiver.got[start:]
        finally:
            load.stop()
    senders = {addr for addr, _ in window}
    assert len(senders) == 1, f"one sender: {senders}"
    seqs = [m["seq"] for _, m in window]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs))), "no datagram lost or out of order under load"
    beats = [i for i, (_, m) in enumerate(window) if m["type"] == "heartbeat"]
    assert len(beats) >= 3, f"heartbeats once a second in the window: {len(beats)}"
    first, last = beats[0], beats[-1]
    span_s = window[last][1]["ts"] - window[first][1]["ts"]  # the sender's clock
    loco = sum(1 for _, m in window[first:last] if m["type"] == "locomotion")
    rate = loco / span_s
    print(f"under load ({load.requests} HTTP requests, {load.ws_messages} WebSocket messages): "
          f"{rate:.1f} locomotion/s over {span_s:.2f} s of the sender's clock")
    assert rate >= MIN_RATE, f"{rate:.1f} locomotion datagrams a second (sender's clock), want >= {MIN_RATE}"
    assert all(m["state"] == "running" for _, m in window if m["type"] == "heartbeat")
