"""The real disk in tests of a full disk: how much is free, and a file that takes space away at once
(``posix_fallocate`` reserves the blocks without writing gigabytes)."""

from __future__ import annotations

import contextlib
import fcntl
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest


@contextlib.contextmanager
def holding_the_disk() -> Iterator[None]:
    """Hold while a test sets thresholds against the free space and takes space away: two such
    tests at once (pytest-xdist's workers) would each see the other's ballast as a full disk."""
    with open(Path(tempfile.gettempdir()) / "cavewalk-tests-disk.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def free_gb(path: Path) -> float:
    return shutil.disk_usage(path).free / 1e9


def need_free_gb(path: Path, gb: float) -> float:
    """The free space of ``path``'s disk (GB); the test fails, saying why, when it is less than ``gb``."""
    free = free_gb(path)
    if free < gb:
        pytest.fail(f"this test needs {gb:g} GB free in {path}, there are {free:.1f}")
    return free


def take_space(ballast: Path, nbytes: int) -> None:
    """A new file ``ballast`` holding ``nbytes`` of the disk (remove it to give them back)."""
    fd = os.open(ballast, os.O_CREAT | os.O_WRONLY)
    try:
        os.posix_fallocate(fd, 0, nbytes)
    finally:
        os.close(fd)
