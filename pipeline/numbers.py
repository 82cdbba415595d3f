"""Numbers for JSON: a float rounded for display, None where it is unknown or not finite (JSON
has no NaN or infinity). Shared by every stage's ``to_dict`` (the lowest level: no imports)."""

from __future__ import annotations

import math
from typing import SupportsFloat


def rounded(x: SupportsFloat | None, nd: int = 3) -> float | None:
    """``x`` rounded to ``nd`` decimals; None when ``x`` is None, NaN or infinite."""
    if x is None:
        return None
    f = float(x)
    return round(f, nd) if math.isfinite(f) else None
