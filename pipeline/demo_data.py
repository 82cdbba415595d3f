"""The real multi-view demo data: Pose2Sim's ``Demo_SinglePerson`` (BSD-3), from PyPI.

``fetch_demo`` runs ``pip download --no-deps pose2sim==0.10.49`` into the cache and
unzips ``Pose2Sim/Demo_SinglePerson/**`` next to it. Idempotent: a completed
extraction is marked by a manifest file and reused.
"""

from __future__ import annotations

import json
import logging
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from pipeline.errors import DataError

log = logging.getLogger(__name__)

POSE2SIM_VERSION = "0.10.49"
DEMO_PREFIX = "Pose2Sim/Demo_SinglePerson/"
MANIFEST = ".cavewalk-demo.json"


@dataclass(frozen=True, slots=True)
class DemoData:
    """Paths inside the extracted demo folder."""

    root: Path

    @property
    def videos(self) -> dict[str, Path]:
        """Camera name -> video file, sorted (cam01 ... cam04)."""
        files = sorted((self.root / "videos").glob("*.mp4"))
        return {p.stem: p for p in files}

    @property
    def calibration(self) -> Path:
        return self.root / "calibration" / "Calib.qca.txt"

    @property
    def intrinsics_images(self) -> Path:
        return self.root / "calibration" / "intrinsics"

    @property
    def config(self) -> Path:
        return self.root / "Config.toml"


def demo_root(cache_dir: Path) -> Path:
    return cache_dir / "data" / f"pose2sim-{POSE2SIM_VERSION}" / "Demo_SinglePerson"


def _download_wheel(dest: Path, progress: Callable[[str], None]) -> Path:
    progress(f"downloading pose2sim=={POSE2SIM_VERSION} from PyPI (wheel, no dependencies)...")
    cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary=:all:",
           "--disable-pip-version-check", "-d", str(dest), f"pose2sim=={POSE2SIM_VERSION}"]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wheels = sorted(dest.glob("pose2sim-*.whl"))
    if proc.returncode != 0 or not wheels:
        raise DataError(
            f"could not download pose2sim=={POSE2SIM_VERSION} with pip: "
            f"{(proc.stderr or proc.stdout).strip().splitlines()[-1:] or ['no output']}"
        )
    return wheels[0]


def fetch_demo(cache_dir: Path, progress: Callable[[str], None] = log.info) -> DemoData:
    """Make sure the demo is extracted under ``cache_dir`` and return its paths."""
    root = demo_root(cache_dir)
    manifest = root / MANIFEST
    if manifest.is_file():
        listed = json.loads(manifest.read_text())["files"]
        if all((root / f).is_file() for f in listed):
            progress(f"demo data ready: {root}")
            return DemoData(root)
        progress("demo data incomplete; extracting again")
    cache_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=cache_dir) as tmp:
        wheel = _download_wheel(Path(tmp), progress)
        try:
            with zipfile.ZipFile(wheel) as zf:
                members = [m for m in zf.infolist() if m.filename.startswith(DEMO_PREFIX)
                           and not m.is_dir()]
                if not members:
                    raise DataError(f"{wheel.name} holds no {DEMO_PREFIX}")
                total = sum(m.file_size for m in members)
                done = 0
                for i, m in enumerate(members, 1):
                    rel = m.filename[len(DEMO_PREFIX):]
                    target = root / rel
                    target.parent.mkdir(parents=True, exist_ok=True)
                    with zf.open(m) as src, target.open("wb") as dst:
                        while chunk := src.read(1 << 20):
                            dst.write(chunk)
                    done += m.file_size
                    if i == len(members) or i % 10 == 0:
                        progress(f"extracting demo: {i}/{len(members)} files, "
                                 f"{done / 1e6:.0f}/{total / 1e6:.0f} MB")
        except zipfile.BadZipFile as exc:
            raise DataError(f"{wheel.name} is not a valid wheel: {exc}") from exc
        files = [m.filename[len(DEMO_PREFIX):] for m in members]
    manifest.write_text(json.dumps({"version": POSE2SIM_VERSION, "files": files}, indent=1))
    progress(f"demo data ready: {root}")
    return DemoData(root)
