"""A teach adaptation reaches the live recogniser in the fuse worker at once and comes off again
(the real pipeline on the simulator; the control message of pipeline.runtime, issue 18 item 3)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from tests.adaptation import FIXED, shows_fixed
from tests.app.conftest import Served, make_settings

pytestmark = pytest.mark.slow


def _fixed(s: dict[str, Any]) -> bool:
    return shows_fixed((s.get("action") or {}).get("probs"))


def test_the_adaptation_is_applied_in_the_running_fuse_worker_and_cleared(tmp_path: Path) -> None:
    with Served(make_settings(tmp_path)) as served:
        served.wait_status(lambda s: s["state"] == "running" and s["action"] is not None)
        pipeline = served.app.state.pipeline
        fuse_pid = pipeline._pipeline.workers()["fuse"]  # the runtime's Pipeline (no public accessor here)
        assert not _fixed(served.wait_status(lambda s: s["action"] is not None)), "the model alone"
        pipeline.set_adaptation(FIXED)
        run: dict[str, Any] = {"n": 0, "ts": None}

        def held(s: dict[str, Any]) -> bool:
            if s.get("ts") != run["ts"]:  # a new snapshot (ten a second)
                run["ts"], run["n"] = s.get("ts"), (run["n"] + 1 if _fixed(s) else 0)
            return run["n"] >= 20  # two seconds of fixed probabilities: no chance match of the real model

        served.wait_status(held)  # the EMA converges to the fixed probabilities within a second
        assert pipeline._pipeline.workers()["fuse"] == fuse_pid, (
            "applied by the running worker, not a restart"
        )
        pipeline.set_adaptation(None)
        served.wait_status(lambda s: s["action"] is not None and not _fixed(s))
        assert pipeline.adaptation is None
