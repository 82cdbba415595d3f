"""Text fields of the study's requests: no NUL bytes or other control characters (issue 15 D3b)."""

from __future__ import annotations

import re
from typing import Annotated

from pydantic import AfterValidator, Field

_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")


def no_control_characters(value: str) -> str:
    m = _CONTROL.search(value)
    if m is not None:
        raise ValueError(
            f"control character U+{ord(m.group()):04X} at position {m.start()} is not allowed "
            f"(line breaks and tabs are)"
        )
    return value


#: Free text (notes): up to 10,000 characters, line breaks allowed, no control characters.
Notes = Annotated[str, Field(max_length=10_000), AfterValidator(no_control_characters)]
#: Why a correction, exclusion or override is made: required, short.
Reason = Annotated[
    str,
    Field(min_length=3, max_length=2_000, description="Why (kept in the audit trail)."),
    AfterValidator(no_control_characters),
]
#: Who makes a change (the experimenter's initials or name); default "operator".
Actor = Annotated[
    str, Field(min_length=1, max_length=48, pattern=r"^[^\x00-\x1f\x7f]+$", description="Who (initials).")
]
