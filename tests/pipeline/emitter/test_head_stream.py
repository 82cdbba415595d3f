"""The ``head`` message (issue 20 item 3): built, validated, and streamed on real sockets with the
locomotion, predicted to the moment it is sent; and over OSC at ``/cave/head/{user_id}``."""

from __future__ import annotations

import json
import threading
import time
from typing import Any

import numpy as np
import pytest
from pythonosc.dispatcher import Dispatcher
from pythonosc.osc_server import ThreadingOSCUDPServer
from runtime.live import Listener  # tests/pipeline/runtime/live.py: the reference receiver in a thread

from pipeline.emitter import EmitterConfig, LocomotionCommand, UdpEmitter, validate_datagram
from pipeline.emitter.protocol import OSC_HEAD_ADDRESS, encode, head_message
from pipeline.errors import InputError
from pipeline.head.config import HeadConfig
from pipeline.head.tracker import HeadEstimate, HeadPose

FORWARD = (0.0, 1.0, 0.0)
UP = (0.0, 0.0, 1.0)


def estimate(ts: float, velocity: tuple[float, float, float] = (1.0, 0.0, 0.0)) -> HeadEstimate:
    return HeadEstimate(3, ts, np.array([0.2, -0.1, 1.65]), np.eye(3), np.asarray(velocity), np.zeros(3))


def good() -> dict[str, Any]:
    return head_message(HeadPose(3, (0.2, -0.1, 1.65), FORWARD, UP, 1.0, 40.0), 7, 1_796_000_000.5)


def test_head_message_follows_the_spec() -> None:
    msg = good()
    assert set(msg) == {"v", "type", "seq", "ts", "user_id", "position_m", "forward", "up", "predicted_ms"}
    assert validate_datagram(encode(msg)) == msg
    assert msg["type"] == "head" and msg["predicted_ms"] == 40.0 and msg["ts"] == 1_796_000_000.5


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"forward": [0.0, 2.0, 0.0]}, "forward: expected a unit vector"),
        ({"up": [0.0, 1.0, 0.0]}, "perpendicular"),
        ({"position_m": [0.0, 1.0]}, r"position_m: expected \[x, y, z\]"),
        ({"predicted_ms": -1.0}, "predicted_ms"),
        ({"user_id": -1}, "user_id"),
        ({"forward": [0.0, "1", 0.0]}, r"forward\[1\]"),
        ({"extra": 1}, "unknown keys"),
        ({"type": "hed"}, "type: expected"),
    ],
)
def test_bad_head_messages_are_refused(change: dict[str, Any], match: str) -> None:
    msg = good() | change
    with pytest.raises(InputError, match=match):
        validate_datagram(json.dumps(msg).encode())
    missing = good()
    del missing["up"]
    with pytest.raises(InputError, match="missing keys"):
        validate_datagram(missing)


def test_head_goes_out_with_locomotion_predicted_to_the_send_time() -> None:
    rx = Listener()
    emitter = UdpEmitter(
        EmitterConfig(rate_hz=60.0, heartbeat_s=0.5),
        [("127.0.0.1", rx.port)],
        head=HeadConfig(display_ms=10.0),
    )
    emitter.set_state("running")
    emitter.start()
    try:
        for _ in range(15):
            captured = time.monotonic() - 0.05  # frames 50 ms old when submitted
            emitter.submit(
                LocomotionCommand(3, "forward", 0.9, 0.0, 1.0, (0.2, -0.1, 0.0), captured),
                (estimate(captured),),
            )
            time.sleep(1 / 30)
    finally:
        emitter.close()
    deadline = time.monotonic() + 5.0  # the last datagrams may still be in the socket's buffer
    while len(rx.of_type("head")) < len(rx.of_type("locomotion")) and time.monotonic() < deadline:
        time.sleep(0.01)
    stats = rx.close()
    summary = stats.summary()
    assert summary["invalid"] == 0 and summary["dropped"] == 0, summary
    heads = [m for m in rx.messages if m is not None and m["type"] == "head"]
    loco = [m for m in rx.messages if m is not None and m["type"] == "locomotion"]
    assert len(heads) == len(loco) >= 15, "one head per navigator with every locomotion datagram"
    for h in heads:
        assert h["user_id"] == 3 and h["forward"] == list(FORWARD) and h["up"] == list(UP)
        assert 60.0 <= h["predicted_ms"] <= 150.0, "the age at sending (>= 50 ms) + display_ms (10 ms)"
        moved = h["position_m"][0] - 0.2  # 1 m/s along x: x moves by the horizon
        assert moved == pytest.approx(h["predicted_ms"] / 1000.0, abs=2e-4)
    seqs = [m["seq"] for m in rx.messages if m is not None]
    assert seqs == list(range(len(seqs))), "head datagrams share the destination's seq"


def test_no_head_messages_when_turned_off_or_without_prediction() -> None:
    for config, expect in ((HeadConfig(enabled=False), None), (HeadConfig(horizon_ms=0.0), 0.0)):
        rx = Listener()
        emitter = UdpEmitter(EmitterConfig(), [("127.0.0.1", rx.port)], head=config)
        captured = time.monotonic()
        emitter.submit(
            LocomotionCommand(3, "still", 0.9, 0.0, 0.0, (0.0, 0.0, 0.0), captured), (estimate(captured),)
        )
        deadline = time.monotonic() + 10.0  # only waits for the locomotion datagram
        while not rx.of_type("locomotion") and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.05)  # a head datagram would follow it at once
        emitter.close()
        rx.close()
        heads = [m for m in rx.messages if m is not None and m["type"] == "head"]
        if expect is None:
            assert heads == []
        else:
            assert len(heads) == 1 and heads[0]["predicted_ms"] == expect
            assert heads[0]["position_m"] == [0.2, -0.1, 1.65]


def test_osc_server_receives_the_head_at_its_users_address() -> None:
    got: list[tuple[Any, ...]] = []
    dispatcher = Dispatcher()
    dispatcher.map(f"{OSC_HEAD_ADDRESS}/*", lambda addr, *args: got.append((addr, *args)))
    server = ThreadingOSCUDPServer(("127.0.0.1", 0), dispatcher)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    emitter = UdpEmitter(
        EmitterConfig(),
        [],
        osc_endpoints=[("127.0.0.1", server.server_address[1])],
        head=HeadConfig(horizon_ms=20.0),
    )
    try:
        captured = time.monotonic()
        sent_unix = time.time()
        emitter.submit(
            LocomotionCommand(3, "left", 0.9, 0.0, 0.5, (0.0, 0.0, 0.0), captured), (estimate(captured),)
        )
        deadline = time.monotonic() + 10.0
        while not got and time.monotonic() < deadline:
            time.sleep(0.02)
    finally:
        emitter.close()
        server.shutdown()
        server.server_close()
    addr, uid, x, y, z, fx, fy, fz, ux, uy, uz, predicted, ts = got[0]
    assert addr == "/cave/head/3" and uid == 3
    assert (x, y, z) == pytest.approx((0.22, -0.1, 1.65), abs=1e-4), "predicted 20 ms at 1 m/s"
    assert (fx, fy, fz, ux, uy, uz) == pytest.approx((*FORWARD, *UP))
    assert predicted == pytest.approx(20.0)
    assert isinstance(ts, float) and abs(ts - sent_unix) < 0.01
