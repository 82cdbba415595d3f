"""What the repositories raise; the app maps them to HTTP statuses (404, 409)."""

from __future__ import annotations


class RecordNotFound(LookupError):
    """The requested row does not exist."""


class StateConflict(Exception):
    """The request contradicts the stored state (duplicate code, session already running ...)."""


class DesignRuleViolation(StateConflict):
    """The request breaks a rule of the study design (409); the operator may override it with a reason.

    rule: a short stable name of the rule (``one_session_per_condition``, ...).
    """

    def __init__(self, rule: str, message: str) -> None:
        super().__init__(message)
        self.rule = rule
