"""Sinks: everything after fusion (issue 16, item 3).

A sink is anything with one method, ``on_result(FrameResult) -> None``, that returns at
once. The UDP/OSC stream is one, and it runs in the fusion worker (:class:`StreamSink`),
so the latency-critical send never shares a process with the web server; the others (the
take recorder, the event log, the viewer's feed) run in the main process on the
collector's thread (``Pipeline.add_sink``).
"""

from __future__ import annotations

import socket
import time
from dataclasses import dataclass
from typing import Protocol

from pipeline.emitter.udp import EmitterConfig, UdpEmitter
from pipeline.head.config import HeadConfig
from pipeline.navigation.stream import frame_commands
from pipeline.results import FrameResult
from pipeline.runtime.stream import StreamBook, StreamBookSpec


class ResultSink(Protocol):
    """Gets every fused result; must return at once (queue your own work)."""

    def on_result(self, result: FrameResult) -> None: ...


@dataclass(frozen=True)
class StreamSpec:
    """What the fusion worker needs to send the stream (picklable; the socket travels as an fd)."""

    config: EmitterConfig
    head: HeadConfig
    book: StreamBookSpec
    sock: socket.socket
    stall_after_s: float


class StreamSink:
    """The UDP/OSC stream in the fusion worker: each result's command goes out at once.

    Its heartbeats say ``starting`` until the first result, ``running`` while results come,
    ``stalled`` once none came for ``stall_after_s`` (:meth:`check`, called by the fusion loop).
    """

    def __init__(self, emitter: UdpEmitter, book: StreamBook, stall_after_s: float) -> None:
        self.emitter = emitter
        self._book = book
        self._stall_after_s = stall_after_s
        self._last_s: float | None = None
        self._state = "starting"
        emitter.set_state("starting")

    @classmethod
    def open(cls, spec: StreamSpec) -> StreamSink:
        book = StreamBook.attach(spec.book)
        emitter = UdpEmitter(spec.config, head=spec.head, shared=book, role="fusion", sock=spec.sock)
        sink = cls(emitter, book, spec.stall_after_s)
        emitter.start()
        return sink

    def on_result(self, result: FrameResult) -> None:
        nav = result.navigation
        streams = None if nav is None else (nav.mode, nav.group.members if nav.group else nav.user_ids)
        self.emitter.submit(frame_commands(result), result.heads, streams)  # announced, then sent
        self._last_s = time.monotonic()
        self._set("running")

    def check(self, now: float) -> None:
        """``running`` -> ``stalled`` when no result came for ``stall_after_s``."""
        if self._state == "running" and self._last_s is not None and now - self._last_s > self._stall_after_s:
            self._set("stalled")

    def send_prompt(self, text: str, label: str, remaining_s: float) -> None:
        self.emitter.send_prompt(text, label, remaining_s)

    def _set(self, state: str) -> None:
        if state != self._state:
            self._state = state
            self.emitter.set_state(state)

    def close(self) -> None:
        """Stop sending (the main process's standby emitter takes over) and detach."""
        self.emitter.close()
        self._book.release()
        self._book.close()
