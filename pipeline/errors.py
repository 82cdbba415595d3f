"""Domain exceptions of the recognition library.

Every error a user can cause (a bad file, a camera that does not open, a
calibration that cannot be solved) is a :class:`CavewalkError`; the command
line and the API turn these into one clear message instead of a traceback.
"""


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
