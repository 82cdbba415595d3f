"""Waiting in tests without racing the machine: conditions with generous deadlines, and free ports.

A test that needs an outcome of another thread or process (a status, a frame, a finished run)
polls for it with :func:`wait_until`, never sleeps a fixed time and then asserts. The deadline
is not a speed requirement: it only ends a test that would otherwise hang, so it is generous
(:data:`GENEROUS_S`, five minutes, under pytest-timeout's ten). On an idle machine the condition
holds within a second or two and the test goes on at once; on a busy CI machine (load 10-25 on
two cores) it may take twenty times as long, and the test still passes. Speed is measured by
``cavewalk bench`` and ``scripts/bench_*.py``, never here.

A test whose outcome depends on the wall clock of the product (a clip that plays for so many
seconds, a timeout in the product) must control that clock instead (longer clips, a looping
source, a configured timeout), so that a slow machine cannot make the outcome different.
"""

from __future__ import annotations

import random
import socket
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

T = TypeVar("T")

#: the deadline of a wait for an outcome that a correct run reaches (only ends a hung test)
GENEROUS_S = 300.0
#: a client's HTTP timeout in tests: a request to a server on a loaded machine may take long
HTTP_TIMEOUT_S = 120.0


def wait_until(
    condition: Callable[[], T | None],
    what: str,
    timeout_s: float = GENEROUS_S,
    poll_s: float = 0.1,
    retry: tuple[type[BaseException], ...] = (),
) -> T:
    """Poll ``condition`` until it returns a truthy value, and return that value.

    ``retry``: exceptions of ``condition`` that mean "not yet" (e.g. ``httpx.TransportError``
    while a server starts); any other exception ends the wait at once. On the deadline an
    AssertionError names ``what`` and the last value (or exception) seen.
    """
    deadline = time.monotonic() + timeout_s
    last: object = None
    while True:
        try:
            value = condition()
        except retry as exc:
            value, last = None, exc
        else:
            if value:
                return value
            last = value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s:.0f} s waiting for {what}; last: {last!r}")
        time.sleep(poll_s)


def _ephemeral_range() -> tuple[int, int]:
    """The ports the kernel hands out on its own (bind to 0, an unbound sendto/connect)."""
    try:
        low, high = Path("/proc/sys/net/ipv4/ip_local_port_range").read_text().split()
        return int(low), int(high)
    except (OSError, ValueError):
        return 32768, 60999


_HANDED_OUT: set[int] = set()


def free_port(kind: socket.SocketKind = socket.SOCK_STREAM, host: str = "127.0.0.1") -> int:
    """A port of ``host`` that nothing holds now, chosen outside the kernel's ephemeral range.

    Never assume 8000/8080 (or any fixed port) is free: other servers and tests run here. A port
    the kernel picks for ``bind(0)`` comes from the ephemeral range, and so does the source port
    of every unbound UDP sender and TCP client on the machine: between the pick and the server's
    own bind, one of them can take it ("Address already in use", a CI failure we had). So the port
    is drawn at random below that range, where the kernel never allocates on its own, checked by
    binding it, and never handed out twice by this process."""
    low, _high = _ephemeral_range()
    top = low - 1 if low > 12000 else 60999
    bottom = max(1024, top - 20000)
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    rng = random.Random()
    for _ in range(200):
        port = rng.randint(bottom, top)
        if port in _HANDED_OUT:
            continue
        with socket.socket(family, kind) as s:
            try:
                s.bind((host, port))
            except OSError:
                continue
        _HANDED_OUT.add(port)
        return port
    raise AssertionError(f"no free port in {bottom}-{top} on {host}")


def free_udp_port(host: str = "127.0.0.1") -> int:
    return free_port(socket.SOCK_DGRAM, host)
