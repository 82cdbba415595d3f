"""Domain exceptions of the recognition library.

Every error a user can cause (a bad file, a camera that does not open, a
calibration that cannot be solved) is a :class:`CavewalkError`; the command
line and the API turn these into one clear message instead of a traceback.
"""

from __future__ import annotations

from pathlib import Path


class CavewalkError(Exception):
    """Base class of every error cavewalk reports to a user."""


class InputError(CavewalkError, ValueError):
    """A file, argument or value given by the user is missing or malformed."""


class ConfigError(CavewalkError):
    """The settings file or environment holds an invalid value."""


class ModelError(CavewalkError):
    """A model file is missing, cannot be loaded, or gives unusable output."""


class SourceError(CavewalkError):
    """A camera, video or image folder cannot be opened or stops delivering."""


class CalibrationError(CavewalkError):
    """A camera cannot be calibrated from what it sees (too few markers, one wall only...)."""


class DataError(CavewalkError):
    """Demo data or another prepared artefact is missing or corrupt."""


def read_user_text(path: str | Path, what: str) -> str:
    """The text of a file a user named, or :class:`InputError` saying why not.

    ``what`` names the file in the message ("protocol file", "motion script"): a missing file
    reads ``<what> not found: <path>``, an unreadable or non-UTF-8 one
    ``<path>: cannot read the <what> (<reason>)``."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{what} not found: {p}")
    try:
        return p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{p}: cannot read the {what} ({exc})") from None
