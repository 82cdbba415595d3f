"""Keep multiprocessing's resource tracker quiet after it died.

The tracker is a helper process that unlinks named semaphores and shared memory left
behind by crashed processes. When it dies (killed, OOM), multiprocessing starts a new one
on the next use, and every name registered with the old one is then unregistered with a
tracker that never heard of it, which prints a ``KeyError: '/mp-...'`` traceback per name.
:func:`guard_resource_tracker` remembers which tracker each name was registered with and
sends an unregister only to that one (a dead tracker's names need none).
"""

from __future__ import annotations

import threading
from multiprocessing import resource_tracker

_lock = threading.Lock()
_installed = False


def guard_resource_tracker() -> None:
    """Install the guard in this process (idempotent)."""
    global _installed
    with _lock:
        if _installed:
            return
        _installed = True
    tracker = resource_tracker._resource_tracker  # type: ignore[attr-defined]
    register, unregister = resource_tracker.register, resource_tracker.unregister
    owners: dict[tuple[str, str], int | None] = {}
    owners_lock = threading.Lock()

    def guarded_register(name: str, rtype: str) -> None:
        register(name, rtype)
        with owners_lock:
            owners[(name, rtype)] = tracker._pid  # type: ignore[attr-defined]

    def guarded_unregister(name: str, rtype: str) -> None:
        with owners_lock:
            owner = owners.pop((name, rtype), None)
        tracker.ensure_running()  # a dead tracker is replaced here (multiprocessing warns once)
        if owner is not None and owner != tracker._pid:  # type: ignore[attr-defined]
            return  # registered with a tracker that has died: the new one does not know it
        unregister(name, rtype)

    resource_tracker.register = guarded_register  # type: ignore[assignment]
    resource_tracker.unregister = guarded_unregister  # type: ignore[assignment]
