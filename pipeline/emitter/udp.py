"""The emitter: protocol-v1 datagrams to every workstation, optionally OSC as well.

``submit()`` hands the emitter the navigator's newest command (or None when no
navigator is tracked); a new command goes out at once, and a background thread
repeats the current one so that ``locomotion`` arrives at ``rate_hz`` on average while
a navigator is tracked (see FRESH_GAP / REPEAT_GAP), and sends a ``heartbeat`` every
``heartbeat_s`` always. Each ``locomotion`` is followed by a ``head`` datagram per head estimate
submitted with its command (issue 20), predicted to the moment it is sent (``HeadConfig``).
Several commands submitted together (issue 20's ``each`` mode: one per navigator) go out together,
one ``locomotion`` datagram each; :meth:`UdpEmitter.set_navigation` adds a ``navigation`` datagram
(the mode and its streams' user ids) after each heartbeat and at once when it changes.
``seq`` counts per destination. Unicast, broadcast and multicast addresses all work
(the socket has SO_BROADCAST and a multicast TTL).

In the live runtime two emitters share one stream (issue 16, item 3): the fusion worker's
(role ``fusion``: every result goes out the moment it is fused) and the main process's
(role ``standby``: the heartbeats while no fusion worker sends). They share the socket and
a :class:`SharedStream` (``pipeline.runtime.stream.StreamBook``): one ``seq`` for every
destination, counted across both and across restarts, the endpoints (the standby sets them,
the fusion emitter follows), the fusion emitter's tick, which tells the standby to
stay silent, and the operator's hold.

While the operator holds navigation (:meth:`UdpEmitter.set_held`), every ``locomotion`` datagram
(and its OSC message) says ``still`` with speed 0 and confidence 1, whatever was submitted; its
user, yaw and position, and the ``head`` datagrams, go on as they are (the walls keep their
perspective). The next datagram built after the call is held: with a shared stream, the one the
fusion worker sends, without a message to it. A ``hold`` datagram says so: whichever emitter
sends the stream announces a change before the first locomotion it affects (or at its next tick,
if that comes first), and repeats ``held: true`` after every heartbeat while the hold lasts (a
workstation started late learns it within a second).
"""

from __future__ import annotations

import functools
import ipaddress
import logging
import socket
import threading
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Literal, Protocol

from pipeline.emitter.config import EmitterConfig, Endpoint
from pipeline.emitter.protocol import (
    HOLD_BY,
    LocomotionCommand,
    encode,
    head_message,
    heartbeat_message,
    hold_message,
    locomotion_message,
    navigation_message,
    osc_head_message,
    osc_locomotion_message,
    prompt_message,
)
from pipeline.errors import InputError
from pipeline.head.config import HeadConfig

if TYPE_CHECKING:  # annotations only: the head tracker pulls scipy, too slow for the settings' import
    from pipeline.head.tracker import HeadEstimate, HeadPose

log = logging.getLogger(__name__)

# Pacing of ``locomotion``, in periods of ``rate_hz``: a fresh command goes out at once unless
# the last datagram left less than FRESH_GAP periods ago (then it is coalesced); the current
# command is repeated REPEAT_GAP periods after it went out, then every period. With results at
# the rate the stream carries every result the moment it comes (a repeat never pre-empts a
# result that is a little late); with slower results repeats fill the gaps: 60 Hz on average.
FRESH_GAP = 0.75
REPEAT_GAP = 1.25
TICK_S = 0.1  # an emitter with a shared stream wakes at least this often (the fusion one ticks it)
Role = Literal["sole", "fusion", "standby"]


class SharedStream(Protocol):
    """The state two emitters of one stream share (``pipeline.runtime.stream.StreamBook``)."""

    @property
    def sent(self) -> int: ...

    @property
    def version(self) -> int: ...

    def peek_seq(self) -> int: ...

    def take_seq(self) -> int: ...

    def add_sent(self, n: int) -> None: ...

    @property
    def held(self) -> bool: ...

    @property
    def hold_by(self) -> str | None: ...

    def set_held(self, held: bool, by: str = "operator") -> None: ...

    def tick(self, now: float | None = None) -> None: ...

    def fusion_sends(self, now: float | None = None) -> bool: ...

    def set_endpoints(self, udp: list[Endpoint], osc: list[Endpoint]) -> None: ...

    def endpoints(self) -> tuple[int, list[Endpoint], list[Endpoint]]: ...


def resolve_endpoint(host: str, port: int) -> Endpoint:
    """(IPv4 address, port) for a host name or address; :class:`InputError` when it does not resolve."""
    if not 1 <= int(port) <= 65535:
        raise InputError(f"workstation {host}:{port}: port must be 1-65535")
    try:
        infos = socket.getaddrinfo(host, int(port), socket.AF_INET, socket.SOCK_DGRAM)
    except (socket.gaierror, UnicodeError) as exc:
        raise InputError(f"workstation {host}:{port}: cannot resolve {host!r} ({exc})") from None
    return str(infos[0][4][0]), int(port)


def _encode_locomotion(cmd: LocomotionCommand, ts_unix: float, seq: int) -> bytes:
    return encode(locomotion_message(cmd, seq, ts_unix))


def _encode_head(pose: HeadPose, ts_unix: float, seq: int) -> bytes:
    return encode(head_message(pose, seq, ts_unix))


def is_multicast(address: str) -> bool:
    try:
        return ipaddress.ip_address(address).is_multicast
    except ValueError:
        return False


def stream_socket(config: EmitterConfig) -> socket.socket:
    """The UDP socket of a stream (broadcast allowed, the multicast TTL set)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
    sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, config.multicast_ttl)
    return sock


class UdpEmitter:
    """Sends the locomotion stream; thread-safe; ``start()``/``stop()`` run the repeat thread.

    shared / role / sock: one stream sent by two emitters (see the module docstring); without
    ``shared`` the emitter is the stream's sole sender (role ``sole``, its own socket).
    """

    def __init__(self, config: EmitterConfig, endpoints: list[Endpoint] | None = None,
                 osc_endpoints: list[Endpoint] | None = None,
                 on_sent: Callable[[float], None] | None = None, head: HeadConfig | None = None, *,
                 shared: SharedStream | None = None, role: Role = "sole",
                 sock: socket.socket | None = None) -> None:
        if (shared is None) != (role == "sole"):
            raise ValueError(f"role {role!r} and shared={shared!r} do not go together")
        self.config = config
        self.head = head or HeadConfig()
        self.role = role
        self._shared = shared
        self._version = -1  # of the shared endpoints this emitter follows (role fusion)
        self._heads: tuple[HeadEstimate, ...] = ()
        self._lock = threading.Lock()
        self._sock = sock if sock is not None else stream_socket(config)
        self._endpoints: list[Endpoint] = []
        self._seq: dict[Endpoint, int] = {}
        self._osc: list[Endpoint] = []  # OSC destinations, sent from the same socket
        self._commands: tuple[LocomotionCommand, ...] = ()  # the current command(s); () = none
        self._navigation: tuple[str, tuple[int, ...]] | None = None  # (mode, user ids) announced
        self._command_at = 0.0
        self._pending = False  # a fresh command waits to be sent
        self._last_was_fresh = False  # the last locomotion datagram carried a new command
        self._last_loco = 0.0
        self._last_beat = 0.0
        self._state = "stopped"
        self._offset = time.time() - time.monotonic()  # monotonic -> Unix seconds
        self._on_sent = on_sent
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._thread: threading.Thread | None = None
        self._sent = 0
        self._hold_by: str | None = None  # who holds navigation, without a shared stream (None: nobody)
        self._announced: str | None = None  # the hold the last ``hold`` datagram of this emitter said
        self.errors = 0
        if role != "fusion":
            self.set_endpoints(endpoints or [])
            if osc_endpoints:
                self.set_osc_endpoints(osc_endpoints)

    @property
    def sent(self) -> int:
        """Datagrams sent (one per destination; with a shared stream, by both of its emitters)."""
        return self._shared.sent if self._shared is not None else self._sent

    # -- configuration -------------------------------------------------------------------
    def set_endpoints(self, endpoints: list[Endpoint]) -> None:
        """Replace the destinations (resolved first; on error nothing changes)."""
        resolved = list(dict.fromkeys(resolve_endpoint(h, p) for h, p in endpoints))
        with self._lock:
            if self._shared is not None:
                self._shared.set_endpoints(resolved, self._osc)
            self._endpoints = resolved
            self._seq = {ep: self._seq.get(ep, 0) for ep in self._endpoints}

    @property
    def endpoints(self) -> list[Endpoint]:
        with self._lock:
            return list(self._endpoints)

    def set_osc_endpoints(self, endpoints: list[Endpoint]) -> None:
        """Replace the OSC destinations of ``/cave/locomotion`` (resolved first; on error nothing changes)."""
        resolved = list(dict.fromkeys(resolve_endpoint(h, p) for h, p in endpoints))
        with self._lock:
            if self._shared is not None:
                self._shared.set_endpoints(self._endpoints, resolved)
            self._osc = resolved

    def _follow(self) -> None:
        """Role fusion: take the endpoints the standby set, when they changed (lock held)."""
        if self._shared is None or self.role != "fusion" or self._shared.version == self._version:
            return
        self._version, self._endpoints, self._osc = self._shared.endpoints()

    def set_state(self, state: str) -> None:
        """The state the heartbeats report; a change goes out at once in an extra heartbeat."""
        heartbeat_message(state, 0, 1.0)  # validates the state name
        with self._lock:
            changed = state != self._state
            self._state = state
            if changed and self._last_beat:
                self._last_beat = time.monotonic() - self.config.heartbeat_s
        if changed:
            self._wake.set()

    @property
    def held(self) -> bool:
        """Whether navigation is held: every locomotion command goes out ``still`` (module docstring)."""
        return self.hold_by is not None

    @property
    def hold_by(self) -> str | None:
        """Who holds navigation: "operator", "session" (a controller session's own), None: nobody."""
        return self._shared.hold_by if self._shared is not None else self._hold_by

    def set_held(self, held: bool, by: str = "operator") -> None:
        """Hold navigation (True; ``by`` the operator or a controller session) or release it; the
        repeat thread sends the held command at once. The fusion emitter only reads the hold: the
        main process's emitter sets it."""
        if self.role == "fusion":
            raise ValueError("the fusion worker's emitter follows the hold; the main process sets it")
        if held and by not in HOLD_BY:
            raise ValueError(f"by must be one of {HOLD_BY}, got {by!r}")
        with self._lock:
            if self._shared is not None:
                self._shared.set_held(held, by)
            self._hold_by = by if held else None
            self._last_loco = 0.0  # the current command (if any) goes out again now, held or not
        self._wake.set()

    # -- sending --------------------------------------------------------------------------
    def submit(self, command: LocomotionCommand | Sequence[LocomotionCommand] | None,
               heads: tuple[HeadEstimate, ...] = (),
               navigation: tuple[str, Sequence[int]] | None = None) -> None:
        """The newest navigator command, or several (one per stream; None or () = no navigator),
        and the navigators' head estimates: sent now, then repeated at the rate (each head
        predicted afresh for each send). ``navigation`` (mode, user ids): as
        :meth:`set_navigation`, in the same step, so no datagram of the old streams can follow
        the announcement of the new ones."""
        commands = () if command is None else (command,) if isinstance(command, LocomotionCommand) \
            else tuple(command)
        if navigation is not None:
            navigation_message(navigation[0], navigation[1], 0, 1.0)  # validates the mode
        with self._lock:
            if navigation is not None:
                self._announce(navigation[0], navigation[1])
            self._commands = commands
            self._heads = tuple(heads) if self.head.enabled else ()
            if not commands:
                return
            now = time.monotonic()
            self._command_at = now
            self._pending = True
            if now - self._last_loco >= FRESH_GAP / self.config.rate_hz:
                self._send_locomotion(commands, now)
                self._pending = False
                self._last_was_fresh = True
                if self._on_sent is not None:
                    self._on_sent(now - commands[0].timestamp_s)
            self._wake.set()  # the repeat thread may be sleeping until the next heartbeat

    def set_navigation(self, mode: str, user_ids: Sequence[int]) -> None:
        """The navigation mode and its streams' user ids, announced in a ``navigation`` datagram
        after every heartbeat and at once when they change (issue 20)."""
        navigation_message(mode, user_ids, 0, 1.0)  # validates the mode
        with self._lock:
            self._announce(mode, user_ids)

    def _announce(self, mode: str, user_ids: Sequence[int]) -> None:
        value = (mode, tuple(sorted(int(u) for u in user_ids)))
        if value != self._navigation:
            self._navigation = value
            self._send_navigation(time.monotonic())

    def _next_gap(self) -> float:
        """Periods after the last datagram when the next is due: soon for a fresh command not
        yet sent (coalesced when commands come faster than the rate); for the first repeat of a
        command a little later than one period (its successor may be just late), then one."""
        if self._pending:
            return FRESH_GAP
        return REPEAT_GAP if self._last_was_fresh else 1.0

    def _send(self, build: Callable[[int], bytes]) -> None:
        self._follow()
        if self._shared is not None:  # one seq per datagram for every destination, shared
            if not self._endpoints:
                return
            # built before its seq is taken, so a sender killed while it builds leaves no gap
            # (the window for a kill is the take and the send alone)
            data = build(self._shared.peek_seq())
            self._shared.take_seq()
            for ep in self._endpoints:
                try:
                    self._sock.sendto(data, ep)
                except OSError as exc:
                    self.errors += 1
                    log.debug("send to %s:%d failed: %s", ep[0], ep[1], exc)
            self._shared.add_sent(len(self._endpoints))
            return
        for ep in self._endpoints:
            seq = self._seq[ep]
            try:
                self._sock.sendto(build(seq), ep)
            except OSError as exc:  # an unreachable host must not stop the others
                self.errors += 1
                log.debug("send to %s:%d failed: %s", ep[0], ep[1], exc)
            self._seq[ep] = seq + 1
            self._sent += 1

    def _send_locomotion(self, cmds: tuple[LocomotionCommand, ...], now: float) -> None:
        osc = []
        by = self.hold_by
        if by != self._announced:  # said before the first locomotion it changes
            self._send_hold(now, by)
        if by is not None:
            cmds = tuple(cmd.held() for cmd in cmds)
        for cmd in cmds:
            ts = cmd.timestamp_s + self._offset
            self._send(functools.partial(_encode_locomotion, cmd, ts))
            if self._osc:
                osc.append(osc_locomotion_message(cmd, ts))
        for est in self._heads:
            pose = est.predict(self.head.horizon_s(now - est.timestamp_s))
            ts_head = est.timestamp_s + self._offset
            self._send(functools.partial(_encode_head, pose, ts_head))
            if self._osc:
                osc.append(osc_head_message(pose, ts_head))
        for ep in self._osc:
            for data in osc:
                try:
                    self._sock.sendto(data, ep)
                except OSError as exc:
                    self.errors += 1
                    log.debug("OSC send failed: %s", exc)
        self._last_loco = now

    def send_prompt(self, text: str, label: str, remaining_s: float) -> None:
        """One ``prompt`` datagram to every workstation now (the recording protocol's instruction)."""
        ts = time.time()
        with self._lock:
            self._send(lambda seq: encode(prompt_message(text, label, remaining_s, seq, ts)))

    def _send_heartbeat(self, now: float) -> None:
        ts = now + self._offset
        state = self._state
        self._send(lambda seq: encode(heartbeat_message(state, seq, ts)))
        self._last_beat = now
        self._send_navigation(now)
        by = self.hold_by
        if by is not None:
            self._send_hold(now, by)

    def _send_hold(self, now: float, by: str | None) -> None:
        ts = now + self._offset
        self._send(lambda seq: encode(hold_message(by, seq, ts)))
        self._announced = by

    def _send_navigation(self, now: float) -> None:
        if self._navigation is None:
            return
        ts = now + self._offset
        mode, ids = self._navigation
        self._send(lambda seq: encode(navigation_message(mode, ids, seq, ts)))

    def tick(self, now: float | None = None) -> None:
        """Send what is due at ``now``: a repeated locomotion and/or a heartbeat."""
        now = time.monotonic() if now is None else now
        if self._shared is not None:
            if self.role == "fusion":
                self._shared.tick(now)
            elif self._shared.fusion_sends(now):
                return  # the fusion worker sends the stream now
        with self._lock:
            cmds = self._commands
            if cmds and now - self._command_at > self.config.stale_after_s:
                cmds = self._commands = ()
            if cmds and now - self._last_loco >= self._next_gap() / self.config.rate_hz:
                self._send_locomotion(cmds, now)
                self._last_was_fresh = self._pending
                self._pending = False
            if now - self._last_beat >= self.config.heartbeat_s:
                self._send_heartbeat(now)
            by = self.hold_by
            if by != self._announced:  # the hold changed: said at once
                self._send_hold(now, by)

    def _run(self) -> None:
        period = 1.0 / self.config.rate_hz
        while not self._stop.is_set():
            try:
                self.tick()
            except Exception:  # the stream must outlive one bad tick
                log.exception("emitter tick failed")
            with self._lock:
                now = time.monotonic()
                wait = self._last_beat + self.config.heartbeat_s - now
                if self._commands:
                    wait = min(wait, self._last_loco + self._next_gap() * period - now)
                if self._shared is not None:
                    wait = min(wait, TICK_S)
            self._wake.wait(max(0.001, wait))
            self._wake.clear()

    def start(self) -> None:
        if self._thread is not None:
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="cavewalk-emitter", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None

    def close(self) -> None:
        self.stop()
        self._sock.close()
