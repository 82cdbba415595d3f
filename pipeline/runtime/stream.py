"""The UDP stream's state shared by the two processes that may send it (issue 16, item 3).

The fusion worker sends the stream (its :class:`~pipeline.emitter.udp.UdpEmitter` gets each
result the moment it is fused); the main process sends the heartbeats while no fusion
worker does (before the first one runs, while one is frozen or restarting, after a stop).
Both send from one socket (the main process's, handed to the worker), so a workstation sees
one sender, and both count ``seq`` in one :class:`StreamBook`, so ``seq`` goes on across a
restarted fusion worker and a hand-over between the two.

A ``StreamBook`` is a small shared-memory segment (int64 words)::

    [0] next seq    [1] datagrams sent    [2] fusion's last tick (monotonic s, float64 bits)
    [3] endpoints version (odd while written)    [4] UDP endpoints    [5] OSC endpoints
    [6 ...] (IPv4 as an int, port) pairs: MAX_ENDPOINTS UDP, then MAX_ENDPOINTS OSC

The main process is the only writer of the endpoints (a seqlock: readers retry a torn
read); the fusion worker writes its tick every ``TICK_S`` (:mod:`pipeline.emitter.udp`)
from its emitter thread. Whoever sends takes ``seq`` from the book; only one of them sends
at a time (the main process stands by while the tick is fresh), so ``seq`` stays
monotonic with no lock a killed worker could leave held.
"""

from __future__ import annotations

import contextlib
import secrets
import socket
import time
from dataclasses import dataclass
from multiprocessing import shared_memory

import numpy as np
from numpy.typing import NDArray

from pipeline.emitter.udp import TICK_S
from pipeline.errors import InputError
from pipeline.runtime.shm import STREAM_PREFIX, attach_segment

Endpoint = tuple[str, int]

MAX_ENDPOINTS = 16
ACTIVE_S = 3 * TICK_S  # a tick younger than this: the fusion worker sends the stream
_HEAD = 6
_WORDS = _HEAD + 4 * MAX_ENDPOINTS


@dataclass(frozen=True, slots=True)
class StreamBookSpec:
    """What a worker needs to attach to the book (picklable)."""

    shm_name: str


class StreamBook:
    """The shared ``seq`` counter, sent count, fusion tick and endpoints (module docstring)."""

    def __init__(self, spec: StreamBookSpec, shm: shared_memory.SharedMemory, owner: bool) -> None:
        self.spec = spec
        self.owner = owner
        self._shm = shm
        self._words: NDArray[np.int64] = np.ndarray((_WORDS,), dtype=np.int64, buffer=shm.buf)
        self._floats: NDArray[np.float64] = self._words.view(np.float64)

    @classmethod
    def create(cls, first_seq: int = 0) -> StreamBook:
        """A new book whose first datagram takes ``first_seq`` (a pipeline that replaces another goes
        on with its ``seq``: a receiver sees one sequence)."""
        name = f"{STREAM_PREFIX}{secrets.token_hex(4)}"
        shm = shared_memory.SharedMemory(name=name, create=True, size=8 * _WORDS)
        book = cls(StreamBookSpec(name), shm, owner=True)
        book._words[:] = 0
        book._words[0] = first_seq
        return book

    @classmethod
    def attach(cls, spec: StreamBookSpec) -> StreamBook:
        return cls(spec, attach_segment(spec.shm_name), owner=False)

    # -- seq and counts (the one sender of the moment) ------------------------------------
    def peek_seq(self) -> int:
        """The ``seq`` the next datagram will take (it is not taken yet)."""
        return int(self._words[0])

    def take_seq(self) -> int:
        """The next ``seq`` (one per datagram, the same for every destination)."""
        seq = int(self._words[0])
        self._words[0] = seq + 1
        return seq

    def add_sent(self, n: int) -> None:
        self._words[1] += n

    @property
    def sent(self) -> int:
        return int(self._words[1])

    # -- who sends -----------------------------------------------------------------------------
    def tick(self, now: float | None = None) -> None:
        """The fusion worker's emitter is alive (called from its thread every TICK_S)."""
        self._floats[2] = time.monotonic() if now is None else now

    def release(self) -> None:
        """The fusion worker is gone (stopped or dead): the main process sends from now on."""
        self._floats[2] = 0.0

    def fusion_sends(self, now: float | None = None) -> bool:
        """Whether the fusion worker sends the stream now (its tick is fresh)."""
        tick = float(self._floats[2])
        now = time.monotonic() if now is None else now
        return tick > 0.0 and now - tick < ACTIVE_S

    # -- endpoints -----------------------------------------------------------------------------
    @property
    def version(self) -> int:
        return int(self._words[3])

    def set_endpoints(self, udp: list[Endpoint], osc: list[Endpoint]) -> None:
        """Replace both lists (resolved IPv4 addresses; the main process only)."""
        if len(udp) > MAX_ENDPOINTS or len(osc) > MAX_ENDPOINTS:
            raise InputError(f"at most {MAX_ENDPOINTS} workstations and {MAX_ENDPOINTS} OSC destinations, "
                             f"got {len(udp)} and {len(osc)}")
        table = np.zeros((2 * MAX_ENDPOINTS, 2), dtype=np.int64)
        for i, (host, port) in enumerate(udp):
            table[i] = (_ip_int(host), port)
        for i, (host, port) in enumerate(osc):
            table[MAX_ENDPOINTS + i] = (_ip_int(host), port)
        v = int(self._words[3])  # even: the one writer is not writing
        self._words[3] = v + 1  # odd: being written
        self._words[4], self._words[5] = len(udp), len(osc)
        self._words[_HEAD:] = table.reshape(-1)
        self._words[3] = v + 2

    def endpoints(self) -> tuple[int, list[Endpoint], list[Endpoint]]:
        """(version, UDP endpoints, OSC endpoints), read consistently."""
        while True:
            v = int(self._words[3])
            if v % 2 == 0:
                n_udp, n_osc = int(self._words[4]), int(self._words[5])
                table = self._words[_HEAD:].reshape(-1, 2).copy()
                if int(self._words[3]) == v:
                    udp = [(_ip_str(int(ip)), int(port)) for ip, port in table[:n_udp]]
                    osc_rows = table[MAX_ENDPOINTS:MAX_ENDPOINTS + n_osc]
                    osc = [(_ip_str(int(ip)), int(port)) for ip, port in osc_rows]
                    return v, udp, osc
            time.sleep(0)

    def close(self) -> None:
        self._words = self._floats = None  # type: ignore[assignment]
        with contextlib.suppress(BufferError):
            self._shm.close()

    def unlink(self) -> None:
        """Remove the segment (the owner; safe twice)."""
        if self._words is not None:
            self.close()
        with contextlib.suppress(FileNotFoundError):
            self._shm.unlink()


def _ip_int(host: str) -> int:
    try:
        return int.from_bytes(socket.inet_aton(host), "big")
    except OSError:
        raise InputError(f"{host!r} is not an IPv4 address") from None


def _ip_str(value: int) -> str:
    return socket.inet_ntoa(value.to_bytes(4, "big"))
