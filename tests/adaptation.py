"""A teach adaptation whose effect on the live outputs is unmistakable, for tests that it reaches
the recogniser (pipeline.takes.teach)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from pipeline.takes.teach import OutputAdaptation

#: the network's output replaced by fixed probabilities (W = 0): forward : left : right = 2 : 3 : 4 in the
#: live probabilities whatever the gate decides (it scales still, or the three movements, together)
FIXED = OutputAdaptation.from_arrays(
    np.zeros((4, 4)), np.log([0.1, 0.2, 0.3, 0.4]), adaptation_id=99, participant_code="P9"
)


def shows_fixed(probs: Mapping[str, float] | None) -> bool:
    """The live probabilities ``probs`` carry FIXED's ratios (no chance match of the real model)."""
    p = probs or {}
    f = p.get("forward", 0.0)
    return f > 0 and abs(p["left"] / f - 1.5) < 0.01 and abs(p["right"] / f - 2.0) < 0.01
