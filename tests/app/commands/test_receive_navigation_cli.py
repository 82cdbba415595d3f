"""``cavewalk receive`` checks the navigation modes' streams (issue 20 item 1): real process, real UDP.

The emitter announces each mode in a ``navigation`` datagram and sends one ``locomotion`` stream
per navigator (each) or one with user_id null (group); a datagram that contradicts the announced
mode is invalid and fails the run."""

from __future__ import annotations

import json
import re
import socket
import subprocess
import time

from pipeline.emitter import EmitterConfig, LocomotionCommand, UdpEmitter
from tests.app.commands.test_runtime_cli import ROOT, cavewalk, free_udp_port, wait_bound


def command(user: int | None, action: str, per_user: bool = True) -> LocomotionCommand:
    return LocomotionCommand(user, action, 0.8, 0.0, 1.0 if action != "still" else 0.0, (0.5, 0.0, 0.0),
                             time.monotonic(), per_user=per_user)


def receive(port: int, count: int) -> subprocess.Popen[str]:
    proc = subprocess.Popen(cavewalk("receive", "--host", "127.0.0.1", "--port", str(port), "--count",
                                     str(count), "--json"),
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_bound(port, proc)
    return proc


def test_receive_checks_each_and_group_streams_and_rejects_a_stream_that_contradicts_the_mode() -> None:
    port = free_udp_port()
    # heartbeat + navigation, 3 x 3 per-user locomotion, navigation (group), 2 group locomotion, 1 bad
    proc = receive(port, 2 + 9 + 1 + 2 + 1)
    try:
        emitter = UdpEmitter(EmitterConfig(rate_hz=60.0, heartbeat_s=30.0, stale_after_s=0.01),
                             [("127.0.0.1", port)])
        emitter.tick()  # the first heartbeat
        emitter.set_navigation("each", [3, 1, 2])
        for _ in range(3):
            emitter.submit([command(1, "forward"), command(2, "left"), command(3, "right")])
            time.sleep(0.03)
        for _ in range(2):  # the announcement and the stream in one step (the pipeline's way)
            emitter.submit(command(None, "still", per_user=False), navigation=("group", [1, 2, 3]))
            time.sleep(0.03)
        time.sleep(0.03)
        emitter.submit(command(2, "left"))  # a per-user stream while group mode is announced
        emitter.close()
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    lines = [json.loads(line) for line in out.splitlines()]
    summary = lines[-1]["summary"]
    messages = [x["message"] for x in lines[:-1] if x.get("valid")]
    assert proc.returncode == 1, f"the contradicting datagram fails the run: {summary}"
    assert summary["invalid"] == 1 and summary["valid"] == 14, summary
    assert any("group mode sends user_id null, got 2" in e for e in summary["errors"]), summary["errors"]
    assert summary["by_user"] == {"1": 3, "2": 3, "3": 3, "group": 2}, summary["by_user"]
    navs = [(m["mode"], m["user_ids"]) for m in messages if m["type"] == "navigation"]
    assert navs == [("each", [1, 2, 3]), ("group", [1, 2, 3])], navs
    loco = [m for m in messages if m["type"] == "locomotion"]
    assert [m["action"] for m in loco if m["user_id"] == 2] == ["left"] * 3
    assert all(m["user_id"] is None for m in loco[-2:]), "the group's stream has user_id null"
    seqs = [m["seq"] for m in messages]
    assert seqs == list(range(len(seqs))), "one seq per datagram per destination, whatever the stream"


def test_receive_prints_the_hold_and_rejects_a_movement_while_held() -> None:
    """The real emitter held and released (``hold`` said before the locomotion it changes), then a
    sender that says ``held: true`` and sends ``forward``: invalid, and the run fails."""
    port = free_udp_port()
    # heartbeat, forward, hold on, still, hold off, forward; then another sender's hold on and forward
    proc = subprocess.Popen(cavewalk("receive", "--host", "127.0.0.1", "--port", str(port), "--count", "8"),
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_bound(port, proc)
    forged = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        emitter = UdpEmitter(EmitterConfig(rate_hz=60.0, heartbeat_s=30.0, stale_after_s=0.01),
                             [("127.0.0.1", port)])
        emitter.tick()
        for held in (False, True, False):
            emitter.set_held(held)
            emitter.submit(command(1, "forward", per_user=False))
            time.sleep(0.03)
        emitter.close()
        for msg in ({"type": "hold", "seq": 0, "held": True, "by": "session"},
                    {"type": "locomotion", "seq": 1, "user_id": 1, "action": "forward", "confidence": 0.8,
                     "yaw_deg": 0.0, "speed_mps": 1.0, "position_m": [0.0, 0.0, 0.0]}):
            forged.sendto(json.dumps({"v": 1, "ts": time.time(), **msg}).encode(), ("127.0.0.1", port))
            time.sleep(0.03)
        out, err = proc.communicate(timeout=60)
    finally:
        forged.close()
        if proc.poll() is None:
            proc.kill()
    said = [m.group(1) for m in re.finditer(r"^#\s*\d+ (\w+(?: \w+)?)", out, re.MULTILINE)]
    assert said == ["heartbeat stopped", "locomotion user", "hold on", "locomotion user", "hold off",
                    "locomotion user", "hold on"], out
    assert re.findall(r"hold on \((\w+)\)", out) == ["operator", "session"], out
    actions = re.findall(r"locomotion user 1 (\w+)", out)
    assert actions == ["forward", "still", "forward"], out
    assert proc.returncode == 1 and out.splitlines()[-1].startswith("INVALID"), (out, err)
    assert "the sender holds navigation, but the action is 'forward'" in err, err
