"""``cavewalk receive`` checks the additive ``head`` messages (issue 20 item 3): real process, real UDP."""

from __future__ import annotations

import json
import socket
import subprocess
import time

import numpy as np

from pipeline.emitter import EmitterConfig, LocomotionCommand, UdpEmitter
from pipeline.head.config import HeadConfig
from pipeline.head.tracker import HeadEstimate
from tests.app.commands.test_runtime_cli import ROOT, cavewalk, free_udp_port, wait_bound


def test_receive_checks_and_prints_head_messages_and_rejects_a_bad_one() -> None:
    port = free_udp_port()
    proc = subprocess.Popen(
        cavewalk("receive", "--host", "127.0.0.1", "--port", str(port), "--count", "7"),
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        wait_bound(port, proc)
        emitter = UdpEmitter(
            EmitterConfig(rate_hz=60.0, heartbeat_s=10.0),
            [("127.0.0.1", port)],
            head=HeadConfig(display_ms=5.0),
        )
        for _ in range(3):  # a locomotion and a head each
            t = time.monotonic()
            emitter.submit(
                LocomotionCommand(2, "forward", 0.8, 0.0, 1.0, (0.0, 0.0, 0.0), t),
                (HeadEstimate(2, t, np.array([0.0, 0.1, 1.7]), np.eye(3), np.zeros(3), np.zeros(3)),),
            )
            time.sleep(0.05)
        emitter.close()
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:  # forward is not a unit vector
            bad = {
                "v": 1,
                "type": "head",
                "seq": 0,
                "ts": 1.0,
                "user_id": 2,
                "position_m": [0, 0, 1],
                "forward": [0, 3, 0],
                "up": [0, 0, 1],
                "predicted_ms": 0,
            }
            s.sendto(json.dumps(bad).encode(), ("127.0.0.1", port))
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 1, "an invalid datagram makes the run fail"
    heads = [line for line in out.splitlines() if " head user 2 " in line]
    assert len(heads) == 3, out
    assert all("forward [0.0, 1.0, 0.0] up [0.0, 0.0, 1.0]" in line for line in heads), heads
    assert len([line for line in out.splitlines() if " locomotion user 2 " in line]) == 3
    assert "6 valid, 1 invalid" in err and "forward: expected a unit vector" in err, err
