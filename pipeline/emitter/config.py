"""The emitter's frozen config: the settings' ``[emitter]`` section and the one parser of
``HOST:PORT`` destinations (no heavy imports here; the emitter itself is :mod:`pipeline.emitter.udp`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

Endpoint = tuple[str, int]


def parse_endpoint(value: str) -> Endpoint:
    """``"host:port"`` (``"[::1]:7000"`` too) -> (host, port); ValueError saying what is wrong.

    The one parser of destinations: workstations, ``--emit`` and OSC all go through it.
    """
    host, sep, port = str(value).rpartition(":")
    if not sep or not host:
        raise ValueError(f"{value!r} must be HOST:PORT")
    try:
        port_i = int(port)
    except ValueError:
        raise ValueError(f"{value!r}: port {port!r} is not a number") from None
    if not 1 <= port_i <= 65535:
        raise ValueError(f"{value!r}: port must be 1-65535")
    return host.strip("[]"), port_i


@dataclass(frozen=True, slots=True)
class EmitterConfig:
    """The UDP stream (protocol v1, SPEC.md): the settings' ``[emitter]`` section.

    rate_hz: locomotion datagrams per second while a navigator is tracked.
    heartbeat_s: a heartbeat this often, always.
    multicast_ttl: hops of multicast datagrams.
    stale_after_s: a command not renewed for this long is no longer repeated.
    osc: ``HOST:PORT`` destinations that also get ``/cave/locomotion`` as OSC.
    seq_file: where ``seq`` is kept across server processes, so that a restarted server goes on
        above every number the last one sent (``pipeline.runtime.stream``); None: ``stream-seq``
        beside the database for ``cavewalk serve`` and ``demo`` (other commands: from 0).
    """

    rate_hz: float = 60.0
    heartbeat_s: float = 1.0
    multicast_ttl: int = 1
    stale_after_s: float = 1.0
    osc: tuple[str, ...] = ()
    seq_file: Path | None = None

    def __post_init__(self) -> None:
        if self.rate_hz <= 0 or self.heartbeat_s <= 0 or self.stale_after_s <= 0:
            raise ValueError(f"rate_hz, heartbeat_s and stale_after_s must be > 0, got {self.rate_hz}, "
                             f"{self.heartbeat_s}, {self.stale_after_s}")
        if not 0 <= self.multicast_ttl <= 255:
            raise ValueError(f"multicast_ttl must be 0-255, got {self.multicast_ttl}")
        for item in self.osc:
            try:
                parse_endpoint(item)
            except ValueError as exc:
                raise ValueError(f"osc: {exc}") from None

    @property
    def osc_endpoints(self) -> list[Endpoint]:
        return [parse_endpoint(item) for item in self.osc]
