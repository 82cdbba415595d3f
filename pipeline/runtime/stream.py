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
    [6] the seq lease written to the seq file (0: no file)
    [7] while navigation is held (every locomotion command goes out ``still``): 1 the operator's
        hold, 2 a controller session's own; 0 not held
    [8 ...] (IPv4 as an int, port) pairs: MAX_ENDPOINTS UDP, then MAX_ENDPOINTS OSC

The main process is the only writer of the endpoints (a seqlock: readers retry a torn
read) and of the hold (one word: the next datagram either sender builds reads it, so a hold
needs no message to the fusion worker and outlives a restarted one); the fusion worker writes
its tick every ``TICK_S`` (:mod:`pipeline.emitter.udp`) from its emitter thread. Whoever sends
takes ``seq`` from the book; only one of them sends at a time (the main process stands by while
the tick is fresh), so ``seq`` stays monotonic with no lock a killed worker could leave held.

``seq`` also goes on across server processes when the book has a ``seq_file``
(``emitter.seq_file``; ``cavewalk serve`` and ``demo`` keep it beside the database): a receiver
that drops a datagram whose ``seq`` went back would otherwise drop everything a restarted server
sends. The file holds a *lease*: a number above every ``seq`` taken so far. A new book starts at
the file's number and writes ``number + SEQ_LEASE`` at once; whoever takes a ``seq`` within
``SEQ_LEASE / 2`` of the lease writes a new one (one small write per ``SEQ_LEASE / 2`` datagrams,
minutes apart). A server killed at any moment therefore left a number above all it sent; one
closed cleanly writes back its next ``seq`` (:meth:`StreamBook.release_lease`), so the next
process goes on without a gap.
"""

from __future__ import annotations

import contextlib
import logging
import secrets
import socket
import time
from dataclasses import dataclass
from multiprocessing import shared_memory
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.emitter.protocol import HOLD_BY
from pipeline.emitter.udp import TICK_S
from pipeline.errors import InputError
from pipeline.runtime.shm import STREAM_PREFIX, attach_segment
from pipeline.takes.files import write_atomic

Endpoint = tuple[str, int]

MAX_ENDPOINTS = 16
ACTIVE_S = 3 * TICK_S  # a tick younger than this: the fusion worker sends the stream
SEQ_LEASE = 100_000  # seq numbers a book may take before it writes its seq file again (about 14 min
# at 120 datagrams a second); a server killed at any moment left its successor a gap of at most this
_LEASE = 6
_HELD = 7
_HEAD = 8
_log = logging.getLogger(__name__)
_WORDS = _HEAD + 4 * MAX_ENDPOINTS


@dataclass(frozen=True, slots=True)
class StreamBookSpec:
    """What a worker needs to attach to the book (picklable)."""

    shm_name: str
    seq_file: str | None = None  # where the seq lease is kept (module docstring); None: none
    lease: int = SEQ_LEASE


class StreamBook:
    """The shared ``seq`` counter, sent count, fusion tick and endpoints (module docstring)."""

    def __init__(self, spec: StreamBookSpec, shm: shared_memory.SharedMemory, owner: bool) -> None:
        self.spec = spec
        self.owner = owner
        self._shm = shm
        self._words: NDArray[np.int64] = np.ndarray((_WORDS,), dtype=np.int64, buffer=shm.buf)
        self._floats: NDArray[np.float64] = self._words.view(np.float64)
        self._lease_failed = False  # this process said the seq file cannot be written

    @classmethod
    def create(cls, first_seq: int | None = None, seq_file: Path | None = None,
               lease: int = SEQ_LEASE) -> StreamBook:
        """A new book whose first datagram takes ``first_seq`` (a pipeline that replaces another goes
        on with its ``seq``: a receiver sees one sequence); None: the number in ``seq_file`` (where
        the last server process left off, module docstring), 0 without one. With a ``seq_file``
        the book writes its lease there at once: an ``OSError`` if it cannot (nothing is created)."""
        if lease < 2:
            raise ValueError(f"lease must be at least 2, got {lease}")
        if first_seq is None:
            first_seq = read_seq_file(seq_file) if seq_file is not None else 0
        if seq_file is not None:
            _write_seq_file(seq_file, first_seq + lease)
        name = f"{STREAM_PREFIX}{secrets.token_hex(4)}"
        shm = shared_memory.SharedMemory(name=name, create=True, size=8 * _WORDS)
        spec = StreamBookSpec(name, str(seq_file) if seq_file is not None else None, lease)
        book = cls(spec, shm, owner=True)
        book._words[:] = 0
        book._words[0] = first_seq
        book._words[_LEASE] = first_seq + lease if seq_file is not None else 0
        return book

    @classmethod
    def attach(cls, spec: StreamBookSpec) -> StreamBook:
        return cls(spec, attach_segment(spec.shm_name), owner=False)

    # -- seq and counts (the one sender of the moment) ------------------------------------
    def peek_seq(self) -> int:
        """The ``seq`` the next datagram will take (it is not taken yet)."""
        return int(self._words[0])

    def take_seq(self) -> int:
        """The next ``seq`` (one per datagram, the same for every destination); renews the lease in
        the seq file once fewer than half of it are left."""
        seq = int(self._words[0])
        self._words[0] = seq + 1
        spec = self.spec
        if spec.seq_file is not None and seq + 1 + spec.lease // 2 > int(self._words[_LEASE]):
            lease = seq + 1 + spec.lease
            self._words[_LEASE] = lease  # a failed write is tried again half a lease later
            try:
                _write_seq_file(Path(spec.seq_file), lease)
            except OSError as exc:  # the stream goes on
                if not self._lease_failed:
                    _log.warning("the stream's seq file %s cannot be written (%s): a server started "
                                 "after a crash may send seq numbers this one sent", spec.seq_file, exc)
                self._lease_failed = True
            else:
                self._lease_failed = False
        return seq

    def release_lease(self) -> None:
        """Write the next ``seq`` to the seq file (a clean close: the next server process goes on
        from here, without a gap), unless the file no longer holds this book's lease (a pipeline
        that took over the stream wrote its own). The book takes no ``seq`` after this."""
        path = self.spec.seq_file
        if path is None:
            return
        try:
            if read_seq_file(Path(path)) == int(self._words[_LEASE]):
                _write_seq_file(Path(path), self.peek_seq())
        except (OSError, InputError) as exc:
            _log.warning("the stream's seq file %s was left as it is (%s)", path, exc)

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

    # -- the operator's hold -----------------------------------------------------------------
    @property
    def held(self) -> bool:
        """Whether navigation is held: every locomotion command is sent ``still``."""
        return bool(self._words[_HELD])

    @property
    def hold_by(self) -> str | None:
        """Who holds navigation: "operator", "session" (a controller session's own), None: nobody."""
        word = int(self._words[_HELD])
        return HOLD_BY[word - 1] if 1 <= word <= len(HOLD_BY) else ("operator" if word else None)

    def set_held(self, held: bool, by: str = "operator") -> None:
        """Hold navigation (``by`` the operator or a session) or release it (the main process only)."""
        if held and by not in HOLD_BY:
            raise ValueError(f"by must be one of {HOLD_BY}, got {by!r}")
        self._words[_HELD] = HOLD_BY.index(by) + 1 if held else 0

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


def read_seq_file(path: Path) -> int:
    """The number a new stream starts from (0: no file yet). A file that does not hold one
    non-negative integer is an ``InputError``: a stream must not start below numbers it sent."""
    try:
        text = Path(path).read_text(encoding="utf-8").strip()
    except FileNotFoundError:
        return 0
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"the stream's seq file {path} cannot be read: {exc}") from None
    if not (text.isascii() and text.isdigit()):
        raise InputError(f"the stream's seq file {path} does not hold a seq number (got {text[:40]!r}); "
                         "remove it to start the stream's seq from 0")
    return int(text)


def check_seq_file(path: Path) -> int:
    """What a server checks at start: the seq file can be read (``InputError``) and written
    (``OSError``; it is written back unchanged: a lease stays valid); its number."""
    value = read_seq_file(path)
    _write_seq_file(path, value)
    return value


def _write_seq_file(path: Path, value: int) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, f"{value}\n".encode("ascii"))


def _ip_int(host: str) -> int:
    try:
        return int.from_bytes(socket.inet_aton(host), "big")
    except OSError:
        raise InputError(f"{host!r} is not an IPv4 address") from None


def _ip_str(value: int) -> str:
    return socket.inet_ntoa(value.to_bytes(4, "big"))
