"""A real UDP receiver for tests of the locomotion stream: every datagram, with its sender."""

from __future__ import annotations

import json
import socket
import threading
from typing import Any


class DatagramRecorder:
    """Every JSON datagram to a bound loopback socket, in arrival order, with its sender address
    (a thread reads it; the receive buffer is large, so a burst is not lost before it is read)."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 * 1024 * 1024)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.1)
        self.port: int = self.sock.getsockname()[1]
        self.got: list[tuple[tuple[str, int], dict[str, Any]]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                data, addr = self.sock.recvfrom(65535)
            except TimeoutError:
                continue
            self.got.append((addr, json.loads(data)))

    def of_type(self, kind: str) -> list[dict[str, Any]]:
        return [m for _, m in list(self.got) if m["type"] == kind]

    def locomotion_since(self, start: int) -> int:
        """Locomotion datagrams among those from index ``start`` on."""
        return sum(1 for _, m in self.got[start:] if m["type"] == "locomotion")

    def fresh_locomotion(self) -> int:
        """Locomotion datagrams that carry a new result (a new ``ts``; repeats carry the old one)."""
        return len({m["ts"] for m in self.of_type("locomotion")})

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
        self.sock.close()
