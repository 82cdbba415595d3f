"""A small C3D reader (pure numpy): point labels, rate, units and 3D point trajectories.

C3D (c3d.org, "The C3D File Format User Guide", Motion Lab Systems 2008): 512-byte blocks.
The header block gives the parameter section's first block, the point count, the analog
values per frame, the first and last frame, the scale factor and the frame rate. The
parameter section (its 4th byte names the processor: 84 Intel, 85 DEC, 86 MIPS/big-endian)
is a chain of group and parameter records; the parameters read here are ``POINT:USED``,
``POINT:SCALE``, ``POINT:RATE``, ``POINT:DATA_START``, ``POINT:UNITS``, ``POINT:LABELS``
(and ``LABELS2``...) and ``ANALOG:USED``. The data section holds, per frame, ``4 x points``
values (x, y, z, residual word: int16 scaled by ``|scale|`` when ``scale > 0``, float32 when
``scale < 0``), then the frame's analog samples. A point whose residual is negative is
invalid (NaN here).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError

BLOCK = 512
F64 = NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class C3DPoints:
    """The 3D points of a C3D file: ``points`` (T, N, 3) in the file's units (NaN = invalid)."""

    labels: tuple[str, ...]
    rate_hz: float
    units: str
    first_frame: int
    points: F64

    def metres(self) -> F64:
        scale = {"mm": 0.001, "cm": 0.01, "m": 1.0}.get(self.units.strip().lower())
        if scale is None:
            raise InputError(f"C3D point units {self.units!r} are not mm, cm or m")
        return self.points * scale

    def index(self, label: str) -> int:
        try:
            return self.labels.index(label)
        except ValueError:
            raise InputError(f"C3D file has no point {label!r}") from None


def _dec_to_ieee(raw: bytes) -> NDArray[np.float32]:
    """DEC (VAX F) float32s to IEEE: swap the 16-bit halves, then divide by 4."""
    words = np.frombuffer(raw, dtype="<u2").reshape(-1, 2)[:, ::-1].copy()
    return (np.frombuffer(words.tobytes(), dtype="<f4") / np.float32(4.0)).astype(np.float32)


class _Fmt:
    def __init__(self, processor: int) -> None:
        if processor not in (84, 85, 86):
            raise InputError(f"C3D: unknown processor type {processor}")
        self.processor = processor
        self.end = ">" if processor == 86 else "<"

    def i16(self, raw: bytes) -> NDArray[np.int16]:
        return np.frombuffer(raw, dtype=f"{self.end}i2")

    def f32(self, raw: bytes) -> NDArray[np.float32]:
        if self.processor == 85:
            return _dec_to_ieee(raw)
        return np.frombuffer(raw, dtype=f"{self.end}f4")


def _parameters(data: bytes, start_block: int) -> tuple[dict[str, dict[str, Any]], _Fmt]:
    base = (start_block - 1) * BLOCK
    if len(data) < base + 4:
        raise InputError("C3D: truncated before the parameter section")
    fmt = _Fmt(data[base + 3])
    groups: dict[int, str] = {}
    params: dict[tuple[int, str], Any] = {}
    pos = base + 4
    end = len(data)
    while pos + 2 <= end:
        n = struct.unpack("b", data[pos : pos + 1])[0]
        gid = struct.unpack("b", data[pos + 1 : pos + 2])[0]
        if n == 0:
            break
        n = abs(n)
        name = data[pos + 2 : pos + 2 + n].decode("latin-1").strip().upper()
        off_at = pos + 2 + n
        offset = int(fmt.i16(data[off_at : off_at + 2])[0])
        body = off_at + 2
        if gid < 0:
            groups[-gid] = name
        else:
            kind = struct.unpack("b", data[body : body + 1])[0]
            ndim = data[body + 1]
            dims = list(data[body + 2 : body + 2 + ndim])
            at = body + 2 + ndim
            count = int(np.prod(dims)) if dims else 1
            size = abs(kind) * count
            raw = data[at : at + size]
            value: Any
            if kind == -1:
                if ndim <= 1:
                    value = raw.decode("latin-1")
                else:
                    width = dims[0]
                    value = [raw[i : i + width].decode("latin-1") for i in range(0, len(raw), width)]
            elif kind == 1:
                value = np.frombuffer(raw, dtype=np.uint8)
            elif kind == 2:
                value = fmt.i16(raw)
            elif kind == 4:
                value = fmt.f32(raw)
            else:
                raise InputError(f"C3D: parameter {name} has an unknown type {kind}")
            params[(gid, name)] = value
        if offset == 0:
            break
        pos = off_at + offset
    out: dict[str, dict[str, Any]] = {g: {} for g in groups.values()}
    for (gid, name), value in params.items():
        out.setdefault(groups.get(gid, f"#{gid}"), {})[name] = value
    return out, fmt


def _scalar(group: dict[str, Any], name: str, default: float) -> float:
    v = group.get(name)
    if v is None or (hasattr(v, "__len__") and len(v) == 0):
        return default
    return float(np.asarray(v).ravel()[0])


def read_c3d(data: bytes, name: str = "c3d") -> C3DPoints:
    """The point trajectories of a C3D file's bytes."""
    if len(data) < BLOCK or data[1] != 0x50:
        raise InputError(f"{name}: not a C3D file (no 0x50 key in the header)")
    params, fmt = _parameters(data, data[0])
    header = fmt.i16(data[:24])
    point = params.get("POINT", {})
    n_points = int(_scalar(point, "USED", float(header[1])))
    n_points = n_points if n_points >= 0 else n_points + 65536
    scale = _scalar(point, "SCALE", float(fmt.f32(data[12:16])[0]))
    rate = _scalar(point, "RATE", float(fmt.f32(data[20:24])[0]))
    start = int(_scalar(point, "DATA_START", float(header[8])))
    start = start if start > 0 else start + 65536
    first, last = int(header[3]), int(header[4])
    if last < first:
        last += 65536
    n_frames = last - first + 1
    analog = params.get("ANALOG", {})
    analog_per_frame = int(header[2]) if header[2] > 0 else 0
    if analog_per_frame == 0 and "USED" in analog:
        analog_per_frame = 0  # header says none per frame
    labels: list[str] = []
    for key in ("LABELS", *(f"LABELS{i}" for i in range(2, 10))):
        v = point.get(key)
        if isinstance(v, list):
            labels += [s.strip() for s in v]
        elif isinstance(v, str) and v:
            labels.append(v.strip())
    labels = labels[:n_points] + [f"P{i}" for i in range(len(labels), n_points)]
    units = point.get("UNITS", "mm")
    units = (units if isinstance(units, str) else "".join(units)).strip() or "mm"
    is_float = scale < 0
    width = 4 if is_float else 2
    per_frame = (4 * n_points + analog_per_frame) * width
    at = (start - 1) * BLOCK
    need = at + per_frame * n_frames
    if rate <= 0 or n_points <= 0 or n_frames <= 0:
        raise InputError(f"{name}: no 3D points (rate {rate}, points {n_points}, frames {n_frames})")
    if len(data) < need:
        n_frames = (len(data) - at) // per_frame
        if n_frames <= 0:
            raise InputError(f"{name}: truncated data section")
    raw = data[at : at + per_frame * n_frames]
    vals = (fmt.f32(raw) if is_float else fmt.i16(raw)).astype(np.float64)
    vals = vals.reshape(n_frames, -1)[:, : 4 * n_points].reshape(n_frames, n_points, 4)
    xyz = vals[..., :3] * (1.0 if is_float else abs(scale))
    residual: NDArray[np.float64] | NDArray[np.int64]
    if is_float:
        whole = np.trunc(vals[..., 3]).astype(np.int64)
        residual = np.where(whole > 32767, whole - 65536, whole)
    else:
        residual = vals[..., 3]
    invalid = (residual < 0) | np.all(xyz == 0, axis=-1)
    xyz[invalid] = np.nan
    return C3DPoints(tuple(labels), rate, units, first, xyz)
