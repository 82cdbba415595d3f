"""The navigation modes over OSC (issue 20 item 1), on a real python-osc server: each mode's
navigators at ``/cave/locomotion/{user_id}``, the group's command at ``/cave/locomotion`` with
user_id -1."""

from __future__ import annotations

import threading
import time
from typing import Any

from pythonosc.dispatcher import Dispatcher
from pythonosc.osc_server import ThreadingOSCUDPServer

from pipeline.emitter import EmitterConfig, LocomotionCommand, UdpEmitter
from pipeline.emitter.protocol import OSC_GROUP_USER_ID


def test_each_mode_streams_per_user_addresses_and_group_the_shared_one() -> None:
    got: list[tuple[Any, ...]] = []
    dispatcher = Dispatcher()
    dispatcher.set_default_handler(lambda addr, *args: got.append((addr, *args)))
    server = ThreadingOSCUDPServer(("127.0.0.1", 0), dispatcher)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    port = server.server_address[1]
    emitter = UdpEmitter(EmitterConfig(rate_hz=50.0), [], osc_endpoints=[("127.0.0.1", port)])
    try:
        t = time.monotonic()
        emitter.submit([LocomotionCommand(4, "left", 0.7, 0.0, 0.5, (0.0, 0.0, 0.0), t, per_user=True),
                        LocomotionCommand(9, "forward", 0.9, 10.0, 1.0, (1.0, 0.0, 0.0), t, per_user=True)])
        time.sleep(0.05)
        emitter.submit(LocomotionCommand(None, "still", 0.6, 0.0, 0.0, (0.5, 0.0, 0.0), time.monotonic()))
        deadline = time.monotonic() + 10.0  # generous: only waits for the three messages
        while len(got) < 3 and time.monotonic() < deadline:
            time.sleep(0.02)
    finally:
        emitter.close()
        server.shutdown()
        server.server_close()
    assert [(g[0], g[1], g[2]) for g in got[:3]] == [
        ("/cave/locomotion/4", 4, "left"),
        ("/cave/locomotion/9", 9, "forward"),
        ("/cave/locomotion", OSC_GROUP_USER_ID, "still"),
    ], got[:3]
