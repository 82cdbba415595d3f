"""The emitter on real sockets (127.0.0.1): the reference receiver and a python-osc server."""

from __future__ import annotations

import threading
import time
from typing import Any

import pytest
from pythonosc.dispatcher import Dispatcher
from pythonosc.osc_message import OscMessage
from pythonosc.osc_server import ThreadingOSCUDPServer
from runtime.live import Listener  # tests/pipeline/runtime/live.py: the reference receiver in a thread

from pipeline.emitter import (
    OSC_ADDRESS,
    OSC_LOCOMOTION_TYPES,
    EmitterConfig,
    LocomotionCommand,
    ReceiverStats,
    UdpEmitter,
    osc_locomotion_message,
)
from pipeline.errors import InputError


def cmd(label: str = "forward", ts: float | None = None) -> LocomotionCommand:
    return LocomotionCommand(2, label, 0.75, 30.0, 1.1, (0.5, -0.25, 0.0),
                             time.monotonic() if ts is None else ts)


def test_datagrams_validate_and_arrive_in_order_at_the_rate() -> None:
    rx_a, rx_b = Listener(), Listener()
    emitter = UdpEmitter(EmitterConfig(rate_hz=60.0, heartbeat_s=0.25),
                         [("127.0.0.1", rx_a.port), ("localhost", rx_b.port)])
    emitter.set_state("running")
    emitter.start()
    submitted = 0
    try:
        t0 = time.monotonic()
        while time.monotonic() - t0 < 1.0:  # commands at 30 Hz; the emitter fills in to 60 Hz
            emitter.submit(cmd("left" if time.monotonic() - t0 > 0.5 else "forward"))
            submitted += 1
            time.sleep(1 / 30)
        elapsed = time.monotonic() - t0
    finally:
        emitter.close()
    for rx in (rx_a, rx_b):
        stats = rx.close()
        summary = stats.summary()
        assert summary["invalid"] == 0, summary["errors"]
        assert summary["dropped"] == 0 and summary["out_of_order"] == 0, summary
        seqs = [m["seq"] for m in rx.messages if m is not None]
        assert seqs == list(range(len(seqs))), "seq counts +1 per datagram per destination, from 0"
        loco = [m for m in rx.messages if m is not None and m["type"] == "locomotion"]
        beats = [m for m in rx.messages if m is not None and m["type"] == "heartbeat"]
        assert len(loco) >= submitted, f"every new command goes out ({submitted}), got {len(loco)}"
        assert len(loco) <= 60 * (elapsed + 0.5) + 1, f"never above the 60 Hz rate, got {len(loco)}"
        assert len(beats) >= 1, "heartbeats go out while locomotion flows"
        assert {m["action"] for m in loco} == {"forward", "left"}
        assert all(b["state"] == "running" for b in beats)


def test_no_locomotion_without_navigator_but_heartbeats_always() -> None:
    rx = Listener()
    emitter = UdpEmitter(EmitterConfig(rate_hz=60.0, heartbeat_s=0.1, stale_after_s=0.1),
                         [("127.0.0.1", rx.port)])
    emitter.start()
    try:
        emitter.submit(cmd())
        emitter.submit(None)  # navigator lost
        time.sleep(0.5)
    finally:
        emitter.close()
    rx.close()
    kinds = [m["type"] for m in rx.messages if m is not None]
    assert kinds.count("locomotion") == 1, "only the command sent before the navigator was lost"
    assert kinds.count("heartbeat") >= 3
    assert all(m["state"] == "stopped" for m in rx.messages if m is not None and m["type"] == "heartbeat")


def test_stale_command_stops_being_repeated() -> None:
    rx = Listener()
    emitter = UdpEmitter(EmitterConfig(rate_hz=100.0, heartbeat_s=10.0, stale_after_s=0.1),
                         [("127.0.0.1", rx.port)])
    emitter.start()
    try:
        emitter.submit(cmd())
        time.sleep(0.6)
        repeated = emitter.sent
        time.sleep(0.4)
        later = emitter.sent
    finally:
        emitter.close()
    rx.close()
    loco = [m for m in rx.messages if m is not None and m["type"] == "locomotion"]
    assert len(loco) >= 1 and repeated >= 1
    assert later == repeated, "a command older than stale_after_s is no longer repeated"
    assert len([m for m in rx.messages if m is not None]) == repeated, "every datagram sent arrived"


def test_osc_server_receives_locomotion() -> None:
    got: list[tuple[Any, ...]] = []
    dispatcher = Dispatcher()
    dispatcher.map(OSC_ADDRESS, lambda addr, *args: got.append((addr, *args)))
    server = ThreadingOSCUDPServer(("127.0.0.1", 0), dispatcher)
    port = server.server_address[1]
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    emitter = UdpEmitter(EmitterConfig(rate_hz=50.0), [], osc_endpoints=[("127.0.0.1", port)])
    try:
        sent_unix = []
        for label in ("forward", "right", "still"):
            sent_unix.append(time.time())
            emitter.submit(cmd(label))  # capture time: now
            time.sleep(0.03)
        deadline = time.monotonic() + 10.0  # generous: only waits for the three messages
        while len(got) < 3 and time.monotonic() < deadline:
            time.sleep(0.02)
    finally:
        emitter.close()
        server.shutdown()
        server.server_close()
    assert [g[2] for g in got[:3]] == ["forward", "right", "still"], "in order"
    addr, user, action, conf, yaw, speed, x, y, z, ts = got[0]
    assert (addr, user, action) == (OSC_ADDRESS, 2, "forward")
    assert conf == pytest.approx(0.75) and yaw == pytest.approx(30.0) and speed == pytest.approx(1.1)
    assert (x, y, z) == pytest.approx((0.5, -0.25, 0.0))
    assert ts > 1_600_000_000, "ts is Unix time"
    assert isinstance(ts, float) and abs(ts - sent_unix[0]) < 0.01, (
        f"ts {ts!r} must resolve milliseconds (a double), sent at {sent_unix[0]!r}; a float32 is "
        "off by up to 64 s at today's epoch"
    )


def test_a_held_emitter_sends_still_on_udp_and_osc_until_released() -> None:
    """The sole emitter (no shared book): held, the current command goes out again at once as
    still (UDP and OSC), speed 0, confidence 1; released, as submitted."""
    got: list[tuple[Any, ...]] = []
    dispatcher = Dispatcher()
    dispatcher.map(OSC_ADDRESS, lambda addr, *args: got.append(args))
    server = ThreadingOSCUDPServer(("127.0.0.1", 0), dispatcher)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    rx = Listener()
    emitter = UdpEmitter(EmitterConfig(rate_hz=20.0, heartbeat_s=100.0), [("127.0.0.1", rx.port)],
                         osc_endpoints=[("127.0.0.1", server.server_address[1])])
    emitter.start()
    try:
        emitter.submit(cmd("right"))
        assert not emitter.held
        time.sleep(0.3)
        emitter.set_held(True)
        assert emitter.held
        time.sleep(0.3)
        emitter.set_held(False)
        time.sleep(0.3)
    finally:
        emitter.close()
        server.shutdown()
        server.server_close()
    stats = rx.close().summary()
    assert stats["invalid"] == 0, stats["errors"]  # the reference receiver checks held -> still
    said = [(m["type"], m["by"] if m["type"] == "hold" else m["action"]) for m in rx.messages
            if m is not None and m["type"] in ("hold", "locomotion")]
    runs = [x for i, x in enumerate(said) if i == 0 or x != said[i - 1]]
    assert runs == [("locomotion", "right"), ("hold", "operator"), ("locomotion", "still"), ("hold", None),
                    ("locomotion", "right")], "each change said before the first locomotion it changes"
    assert stats["held"] == {next(iter(stats["held"])): False}, "the last word: released"
    loco = [m for m in rx.messages if m is not None and m["type"] == "locomotion"]
    actions = [m["action"] for m in loco]
    first_still, last_still = actions.index("still"), len(actions) - 1 - actions[::-1].index("still")
    assert set(actions[:first_still]) == {"right"} and set(actions[last_still + 1:]) == {"right"}, actions
    assert set(actions[first_still:last_still + 1]) == {"still"}, "one held stretch, nothing else in it"
    assert last_still - first_still >= 3, f"held for 0.3 s at 20 Hz: {actions}"
    held = loco[first_still]
    assert (held["speed_mps"], held["confidence"], held["yaw_deg"], held["position_m"]) == (
        0.0, 1.0, 30.0, [0.5, -0.25, 0.0])
    osc_actions = [g[1] for g in got]
    assert "still" in osc_actions and osc_actions[0] == "right" and osc_actions[-1] == "right", osc_actions
    assert all(g[4] == 0.0 for g in got if g[1] == "still"), "OSC's held speed is 0 too"


def test_who_holds_is_said_and_a_change_of_holder_is_said_again() -> None:
    """A controller session's own hold says ``by: "session"``; the operator taking it over is said
    before the next locomotion, the held stream goes on still throughout; a bad holder changes nothing."""
    rx = Listener()
    emitter = UdpEmitter(EmitterConfig(rate_hz=20.0, heartbeat_s=100.0), [("127.0.0.1", rx.port)])
    emitter.start()
    try:
        emitter.submit(cmd("forward"))
        emitter.set_held(True, "session")
        assert emitter.hold_by == "session"
        time.sleep(0.3)
        emitter.set_held(True, "operator")
        with pytest.raises(ValueError, match="by must be one of"):
            emitter.set_held(True, "someone")
        assert emitter.hold_by == "operator"
        time.sleep(0.3)
        emitter.set_held(False, "operator")
        time.sleep(0.3)
    finally:
        emitter.close()
    stats = rx.close().summary()
    assert stats["invalid"] == 0, stats["errors"]
    said = [(m["type"], m["by"] if m["type"] == "hold" else m["action"]) for m in rx.messages
            if m is not None and m["type"] in ("hold", "locomotion")]
    runs = [x for i, x in enumerate(said) if i == 0 or x != said[i - 1]]
    if runs[0] == ("locomotion", "forward"):  # sent before the hold was set
        runs = runs[1:]
    assert runs == [("hold", "session"), ("locomotion", "still"), ("hold", "operator"),
                    ("locomotion", "still"), ("hold", None), ("locomotion", "forward")], runs


def test_osc_locomotion_message_types_ts_as_a_double() -> None:
    ts = 1_796_148_736.123456
    message = OscMessage(osc_locomotion_message(cmd("left"), ts))
    assert message.address == OSC_ADDRESS
    assert b"," + OSC_LOCOMOTION_TYPES.encode() in message.dgram and OSC_LOCOMOTION_TYPES.endswith("d")
    user, action, conf, _yaw, _speed, _x, _y, _z, got = message.params
    assert (user, action, conf) == (2, "left", pytest.approx(0.75))
    assert got == ts, "a double carries the microseconds"


def test_bad_workstation_rejected_and_destinations_unchanged() -> None:
    emitter = UdpEmitter(EmitterConfig(), [("127.0.0.1", 9999)])
    try:
        with pytest.raises(InputError, match="cannot resolve"):
            emitter.set_endpoints([("127.0.0.1", 9998), ("no-such-host.invalid", 9000)])
        with pytest.raises(InputError, match="port must be 1-65535"):
            emitter.set_endpoints([("127.0.0.1", 70000)])
        assert emitter.endpoints == [("127.0.0.1", 9999)], "a rejected list changes nothing"
    finally:
        emitter.close()


def test_broadcast_and_multicast_addresses_are_accepted() -> None:
    emitter = UdpEmitter(EmitterConfig(), [("255.255.255.255", 9), ("239.1.2.3", 9)])
    try:
        emitter.tick()  # sending to them must not raise
        assert emitter.endpoints == [("255.255.255.255", 9), ("239.1.2.3", 9)]
    finally:
        emitter.close()


def test_the_receiver_refuses_a_movement_from_a_sender_that_holds() -> None:
    from pipeline.emitter import encode, hold_message, locomotion_message

    stats = ReceiverStats()
    move = cmd("forward", ts=1.0)
    stats.feed(encode(locomotion_message(move, 0, 1.0)), "a", 1.01)
    stats.feed(encode(hold_message("operator", 1, 1.0)), "a", 1.01)
    stats.feed(encode(locomotion_message(move.held(), 2, 1.0)), "a", 1.01)
    stats.feed(encode(locomotion_message(move, 3, 1.0)), "a", 1.01)  # contradicts its own hold
    stats.feed(encode(locomotion_message(move, 0, 1.0)), "b", 1.01)  # another sender: not held
    stats.feed(encode(hold_message(None, 4, 1.0)), "a", 1.01)
    stats.feed(encode(locomotion_message(move, 5, 1.0)), "a", 1.01)
    s = stats.summary()
    assert (s["valid"], s["invalid"]) == (6, 1), s
    assert s["errors"] == ["locomotion: the sender holds navigation, but the action is 'forward'"]
    assert s["held"] == {"a": False} and s["by_type"]["hold"] == 2
    for bad in ({"held": 1}, {"held": "true"}, {"held": None}, {"by": "someone"}, {"by": None}):
        stats.feed(encode(hold_message("session", 6, 1.0) | bad), "a", 1.01)
    stats.feed(encode(hold_message(None, 7, 1.0) | {"by": "operator"}), "a", 1.01)  # released by nobody
    stats.feed(encode({k: v for k, v in hold_message(None, 8, 1.0).items() if k != "by"}), "a", 1.01)
    assert stats.summary()["invalid"] == 8


def test_receiver_counts_drops_and_reordering() -> None:
    from pipeline.emitter import encode, heartbeat_message

    stats = ReceiverStats()
    for seq in (0, 1, 4, 3, 5):
        stats.feed(encode(heartbeat_message("running", seq, 1.0)), "a", 2.0)
    stats.feed(b"garbage", "a", 2.0)
    s = stats.summary()
    assert (s["valid"], s["invalid"], s["dropped"], s["out_of_order"]) == (5, 1, 2, 1)
