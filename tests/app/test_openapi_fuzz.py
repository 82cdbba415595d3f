"""Schemathesis against the OpenAPI schema: generated requests to every operation never get a 5xx.

Bounded: a few examples per operation, on the app with the real pipeline on the simulator.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import hypothesis
import pytest
import schemathesis
from hypothesis import HealthCheck, given

from tests.app.conftest import Served, make_settings

pytestmark = pytest.mark.slow

EXAMPLES_PER_OPERATION = 4
#: Operations left out: starting a calibration renders and solves four camera images (seconds of CPU per
#: example; tests/app/test_calibration_api.py covers it); starting a plan runs a Monte Carlo for seconds to
#: a minute (tests/app/test_plan_api.py covers it); the WebSocket is not an OpenAPI operation.
SKIP = {("POST", "/api/v1/calibration/runs"), ("POST", "/api/v1/plan")}


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    with Served(make_settings(Path(tmp_path_factory.mktemp("fuzz")))) as s:
        for code, cond in (("P01", "CC"), ("P02", "EC")):  # some rows so that ids in paths sometimes exist
            pid = httpx.post(f"{s.base}/api/v1/participants", json={"code": code}).json()["id"]
            httpx.post(f"{s.base}/api/v1/sessions", json={"participant_id": pid, "condition": cond})
        yield s


def test_no_operation_answers_5xx(served: Served) -> None:
    schema = schemathesis.openapi.from_dict(served.app.openapi())
    operations = [r.ok() for r in schema.get_all_operations()]
    assert len(operations) >= 25, "every resource's routes are in the schema"
    failures: list[str] = []
    tried = 0
    for operation in operations:
        if (operation.method.upper(), operation.path) in SKIP:
            continue
        tried += 1
        fuzz(operation, served.base, failures)
    assert tried >= 25
    assert not failures, "server errors:\n" + "\n".join(failures)


def fuzz(op: Any, base_url: str, failures: list[str]) -> None:
    """Send a few generated requests of one operation; note every 5xx."""

    @given(case=op.as_strategy())
    @hypothesis.settings(
        max_examples=EXAMPLES_PER_OPERATION,
        deadline=None,
        database=None,
        derandomize=True,
        suppress_health_check=list(HealthCheck),
    )
    def run(case: schemathesis.Case) -> None:
        response = case.call(base_url=base_url, timeout=30)
        if response.status_code >= 500:
            failures.append(
                f"{op.label} -> {response.status_code}: {response.text[:300]}  ({case.body!r}, "
                f"{case.path_parameters!r}, {case.query!r})"
            )

    run()
