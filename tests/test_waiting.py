"""The tests' own port picking: outside the kernel's ephemeral range, never the same twice."""

from __future__ import annotations

import socket
from collections.abc import Iterator

import pytest

import tests.waiting as waiting
from tests.waiting import _ephemeral_range, free_port, free_udp_port


def test_ports_come_from_below_the_ephemeral_range_and_are_never_repeated() -> None:
    low, high = _ephemeral_range()
    ports = [free_port() for _ in range(40)] + [free_udp_port() for _ in range(40)]
    assert len(set(ports)) == len(ports)
    assert all(not low <= p <= high for p in ports), [p for p in ports if low <= p <= high]
    assert all(p >= 1024 for p in ports)


def test_a_port_is_free_to_bind_when_handed_out() -> None:
    for kind, pick in ((socket.SOCK_STREAM, free_port), (socket.SOCK_DGRAM, free_udp_port)):
        port = pick()
        with socket.socket(socket.AF_INET, kind) as s:
            s.bind(("127.0.0.1", port))


def test_a_held_port_is_not_handed_out(monkeypatch: pytest.MonkeyPatch) -> None:
    held = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    held.bind(("127.0.0.1", free_udp_port()))
    taken = held.getsockname()[1]
    waiting._HANDED_OUT.discard(taken)  # only the bind check can refuse it now
    drawn: list[int] = []

    def candidates(bottom: int, top: int) -> Iterator[int]:
        yield taken
        yield taken
        # then every other port of the range: any of them may be held by another process here
        yield from (p for p in range(bottom, top + 1) if p != taken)

    class Rng:
        draws: Iterator[int] | None = None

        def randint(self, a: int, b: int) -> int:
            if Rng.draws is None:
                Rng.draws = candidates(a, b)
            drawn.append(next(Rng.draws))
            return drawn[-1]

    monkeypatch.setattr(waiting.random, "Random", Rng)
    try:
        assert free_udp_port() != taken
        assert drawn[:2] == [taken, taken]  # it was offered the held port and refused it
    finally:
        held.close()
