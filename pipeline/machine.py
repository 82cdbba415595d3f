"""Facts about the machine a model was prepared on or a figure was measured on.

``machine_facts()`` names the CPU (model, the instruction-set extensions int8 and float
inference speed depend on: AVX2, AVX-512, VNNI, AMX), its cores, and onnxruntime (version,
the execution providers it offers). ``cavewalk models prepare`` records them in each model's
JSON and prints them; ``cavewalk bench`` and the benchmark scripts can do the same, so that
every figure names its machine. Reads ``/proc/cpuinfo`` on Linux, ``platform`` elsewhere.
"""

from __future__ import annotations

import contextlib
import os
import platform
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

CPUINFO = Path("/proc/cpuinfo")

#: extension -> the /proc/cpuinfo flags that show it (any of them)
EXTENSIONS: dict[str, tuple[str, ...]] = {
    "avx2": ("avx2",),
    "fma": ("fma",),
    "avx512f": ("avx512f",),
    "avx512_bw": ("avx512bw",),
    "avx512_vnni": ("avx512_vnni",),
    "avx_vnni": ("avx_vnni",),
    "avx512_bf16": ("avx512_bf16",),
    "amx": ("amx_tile", "amx_int8", "amx_bf16"),
}


@dataclass(frozen=True, slots=True)
class MachineFacts:
    """cpu_model: the CPU's name. extensions: the EXTENSIONS it has (sorted). logical_cores /
    physical_cores: of the machine (physical None when unknown); usable_cores: those this
    process may run on. onnxruntime: its version (None when not installed); providers: the
    execution providers it offers, in its order of preference."""

    cpu_model: str
    extensions: tuple[str, ...]
    logical_cores: int
    physical_cores: int | None
    usable_cores: int
    system: str
    onnxruntime: str | None
    providers: tuple[str, ...] = field(default_factory=tuple)

    @property
    def vnni(self) -> bool:
        """int8 dot-product instructions (AVX-512 VNNI or AVX-VNNI): int8 gains most with them."""
        return "avx512_vnni" in self.extensions or "avx_vnni" in self.extensions

    def as_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out["extensions"] = list(self.extensions)
        out["providers"] = list(self.providers)
        return out

    def summary(self) -> str:
        """One line, e.g. ``AMD EPYC, 2 cores (2 usable), AVX2 FMA, no AVX-512/VNNI/AMX; onnxruntime
        1.x (CPU)``."""
        have = [e.upper().replace("_", "-") for e in self.extensions]
        lacks = [name for name, keys in (("AVX-512", ("avx512f",)), ("VNNI", ("avx512_vnni", "avx_vnni")),
                                         ("AMX", ("amx",))) if not any(k in self.extensions for k in keys)]
        cores = f"{self.logical_cores} cores ({self.usable_cores} usable"
        cores += f", {self.physical_cores} physical)" if self.physical_cores else ")"
        isa = " ".join(have) or "no AVX2"
        if lacks:
            isa += ", no " + "/".join(lacks)
        offered = ", ".join(p.removesuffix("ExecutionProvider") for p in self.providers)
        ort = f"onnxruntime {self.onnxruntime} ({offered})" if self.onnxruntime else "no onnxruntime"
        return f"{self.cpu_model}, {cores}, {isa}; {ort}"


def parse_cpuinfo(text: str) -> tuple[str | None, set[str]]:
    """(model name, flags) of the first processor in a /proc/cpuinfo text."""
    model: str | None = None
    flags: set[str] = set()
    for line in text.splitlines():
        key, _, value = line.partition(":")
        key = key.strip().lower()
        if key == "model name" and model is None:
            model = value.strip()
        elif key in ("flags", "features") and not flags:
            flags = set(value.split())
    return model, flags


def extensions_of(flags: set[str]) -> tuple[str, ...]:
    return tuple(sorted(name for name, keys in EXTENSIONS.items() if any(k in flags for k in keys)))


def machine_facts(cpuinfo: Path = CPUINFO) -> MachineFacts:
    """The facts of this machine (see :class:`MachineFacts`)."""
    model: str | None = None
    flags: set[str] = set()
    with contextlib.suppress(OSError):
        model, flags = parse_cpuinfo(cpuinfo.read_text(errors="replace"))
    try:
        import psutil

        physical = psutil.cpu_count(logical=False)
    except Exception:  # psutil missing or unable to count
        physical = None
    try:
        usable = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        usable = os.cpu_count() or 1
    try:
        import onnxruntime as ort

        ort_version: str | None = str(ort.__version__)
        providers = tuple(str(p) for p in ort.get_available_providers())
    except ImportError:
        ort_version, providers = None, ()
    return MachineFacts(
        cpu_model=model or platform.processor() or platform.machine() or "unknown CPU",
        extensions=extensions_of(flags),
        logical_cores=os.cpu_count() or 1,
        physical_cores=physical,
        usable_cores=usable,
        system=f"{platform.system()} {platform.release()} {platform.machine()}",
        onnxruntime=ort_version,
        providers=providers,
    )


def machine_fingerprint(cpuinfo: Path = CPUINFO) -> dict[str, Any]:
    """What a result tuned to a machine must match (``cavewalk tune``): the CPU model, the core count
    and onnxruntime's version; cheap (no onnxruntime import), for every settings load."""
    from importlib import metadata

    model: str | None = None
    with contextlib.suppress(OSError):
        model, _ = parse_cpuinfo(cpuinfo.read_text(errors="replace"))
    ort_version: str | None = None
    for dist in ("onnxruntime", "onnxruntime-gpu", "onnxruntime-openvino", "onnxruntime-directml"):
        with contextlib.suppress(metadata.PackageNotFoundError):
            ort_version = metadata.version(dist)
            break
    return {"cpu_model": model or platform.processor() or platform.machine() or "unknown CPU",
            "logical_cores": os.cpu_count() or 1, "onnxruntime": ort_version}
