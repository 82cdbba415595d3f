"""The reference workstation receiver: validates each datagram, counts drops by ``seq``,
measures rate and latency (``ts`` against the receive time).

It also checks the navigation modes (issue 20): once a sender has announced its mode in a
``navigation`` datagram, each ``locomotion`` must fit it (``group``: ``user_id`` null; ``each``
and ``single``: a user id among those announced); one that does not counts as invalid."""

from __future__ import annotations

import socket
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pipeline.emitter.protocol import validate_datagram
from pipeline.errors import InputError


@dataclass
class ReceiverStats:
    """Counters of a receive run (``sources`` keyed by the sender's address)."""

    received: int = 0
    valid: int = 0
    invalid: int = 0
    dropped: int = 0
    out_of_order: int = 0
    by_type: dict[str, int] = field(default_factory=dict)
    latencies_ms: list[float] = field(default_factory=list)
    first_s: float | None = None
    last_s: float | None = None
    errors: list[str] = field(default_factory=list)
    by_user: dict[str, int] = field(default_factory=dict)  # locomotion per stream ("group" = null)
    navigation: dict[str, dict[str, Any]] = field(default_factory=dict)  # sender -> last announcement
    held: dict[str, bool] = field(default_factory=dict)  # sender -> its last ``hold`` announcement
    _next_seq: dict[str, int] = field(default_factory=dict)

    def feed(self, data: bytes, sender: str, recv_unix: float) -> dict[str, Any] | None:
        """Account one datagram; returns the message if valid."""
        self.received += 1
        self.first_s = recv_unix if self.first_s is None else self.first_s
        self.last_s = recv_unix
        try:
            msg = validate_datagram(data)
            if msg["type"] == "locomotion":
                self._check_stream(msg, sender)
        except InputError as exc:
            self.invalid += 1
            if len(self.errors) < 20:
                self.errors.append(str(exc))
            return None
        self.valid += 1
        self.by_type[msg["type"]] = self.by_type.get(msg["type"], 0) + 1
        expected = self._next_seq.get(sender)
        seq = int(msg["seq"])
        if expected is not None:
            if seq > expected:
                self.dropped += seq - expected
            elif seq < expected:
                self.out_of_order += 1
        if expected is None or seq >= expected:
            self._next_seq[sender] = seq + 1
        if msg["type"] == "locomotion":
            self.latencies_ms.append((recv_unix - float(msg["ts"])) * 1000.0)
            stream = "group" if msg["user_id"] is None else str(msg["user_id"])
            self.by_user[stream] = self.by_user.get(stream, 0) + 1
        elif msg["type"] == "navigation":
            self.navigation[sender] = {"mode": msg["mode"], "user_ids": list(msg["user_ids"])}
        elif msg["type"] == "hold":
            self.held[sender] = bool(msg["held"])
        return msg

    def _check_stream(self, msg: dict[str, Any], sender: str) -> None:
        """InputError for a ``locomotion`` that contradicts the sender's announced navigation mode."""
        if self.held.get(sender) and msg["action"] != "still":
            raise InputError(f"locomotion: the sender holds navigation, but the action is {msg['action']!r}")
        nav = self.navigation.get(sender)
        if nav is None:  # nothing announced (a sender before issue 20): no mode to check against
            return
        user, mode = msg["user_id"], nav["mode"]
        if mode == "group" and user is not None:
            raise InputError(f"locomotion: group mode sends user_id null, got {user!r}")
        if mode != "group" and user is None:
            raise InputError(f"locomotion: user_id null is the group's stream, but the mode is {mode}")
        if mode != "group" and user not in nav["user_ids"]:
            raise InputError(f"locomotion: user {user} is not among the announced navigators "
                             f"{nav['user_ids']} ({mode} mode)")

    def summary(self) -> dict[str, Any]:
        span = (self.last_s - self.first_s) if self.first_s is not None and self.last_s is not None else 0.0
        lat = np.asarray(self.latencies_ms, dtype=np.float64)
        loco = self.by_type.get("locomotion", 0)
        return {
            "received": self.received,
            "valid": self.valid,
            "invalid": self.invalid,
            "dropped": self.dropped,
            "out_of_order": self.out_of_order,
            "by_type": dict(self.by_type),
            "duration_s": round(span, 3),
            "rate_hz": round(self.received / span, 2) if span > 0 else None,
            "locomotion_rate_hz": round((loco - 1) / span, 2) if span > 0 and loco > 1 else None,
            "latency_ms": ({k: round(float(np.percentile(lat, q)), 3) for k, q in
                            (("p50", 50), ("p95", 95), ("p99", 99))} if lat.size else None),
            "errors": list(self.errors),
            "by_user": dict(self.by_user),
            "navigation": {k: dict(v) for k, v in self.navigation.items()},
            "held": dict(self.held),
        }


def open_receiver_socket(port: int, host: str = "0.0.0.0",
                         multicast_group: str | None = None) -> socket.socket:
    """A bound UDP socket (joined to ``multicast_group`` if given); InputError if the port is taken."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except OSError as exc:
        sock.close()
        raise InputError(f"cannot listen on UDP {host}:{port}: {exc.strerror}") from None
    if multicast_group:
        mreq = struct.pack("4s4s", socket.inet_aton(multicast_group), socket.inet_aton("0.0.0.0"))
        sock.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, mreq)
    return sock


def receive(sock: socket.socket, *, count: int | None = None, duration_s: float | None = None,
            on_message: Callable[[dict[str, Any] | None, bytes], None] | None = None,
            should_stop: Callable[[], bool] = lambda: False) -> ReceiverStats:
    """Receive until ``count`` datagrams, ``duration_s`` seconds, or ``should_stop()``."""
    stats = ReceiverStats()
    end = time.monotonic() + duration_s if duration_s is not None else None
    sock.settimeout(0.1)
    while not should_stop():
        if count is not None and stats.received >= count:
            break
        if end is not None and time.monotonic() >= end:
            break
        try:
            data, addr = sock.recvfrom(65535)
        except TimeoutError:
            continue
        msg = stats.feed(data, f"{addr[0]}:{addr[1]}", time.time())
        if on_message is not None:
            on_message(msg, data)
    return stats
