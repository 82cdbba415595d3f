"""Emitter stage: protocol-v1 UDP datagrams (and optional OSC) to the CAVE workstations."""

from pipeline.emitter.config import EmitterConfig
from pipeline.emitter.protocol import (
    OSC_ADDRESS,
    OSC_LOCOMOTION_TYPES,
    PROTOCOL_VERSION,
    STATES,
    LocomotionCommand,
    encode,
    heartbeat_message,
    hold_message,
    locomotion_message,
    osc_locomotion_message,
    validate_datagram,
)
from pipeline.emitter.receiver import ReceiverStats, open_receiver_socket, receive
from pipeline.emitter.udp import UdpEmitter, resolve_endpoint

__all__ = [
    "OSC_ADDRESS",
    "OSC_LOCOMOTION_TYPES",
    "PROTOCOL_VERSION",
    "STATES",
    "EmitterConfig",
    "LocomotionCommand",
    "ReceiverStats",
    "UdpEmitter",
    "encode",
    "heartbeat_message",
    "hold_message",
    "locomotion_message",
    "open_receiver_socket",
    "osc_locomotion_message",
    "receive",
    "resolve_endpoint",
    "validate_datagram",
]
