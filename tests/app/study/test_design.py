"""Counterbalancing, the minimum gap between sessions, completeness."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

import pytest

from app.study.data import ParticipantRecord, ResponseRecord, SessionRecord, StudyData
from app.study.design import (
    DesignConfig,
    completeness,
    counterbalanced_orders,
    design_summary,
    gap_warnings,
    next_first_condition,
    order_for,
)

T0 = datetime(2026, 3, 2, 16, 0, tzinfo=UTC)


@pytest.mark.parametrize("n", [0, 1, 2, 7, 20])
def test_counterbalanced_halves(n: int) -> None:
    orders = counterbalanced_orders(n)
    cc_first = sum(o == ("CC", "EC") for o in orders)
    ec_first = sum(o == ("EC", "CC") for o in orders)
    assert cc_first + ec_first == n
    assert abs(cc_first - ec_first) <= 1
    for k in range(1, n + 1):  # balanced at every point as participants are added
        prefix = orders[:k]
        assert abs(sum(o[0] == "CC" for o in prefix) - sum(o[0] == "EC" for o in prefix)) <= 1


def test_next_first_condition_fills_the_smaller_group() -> None:
    assert next_first_condition([]) == "CC"
    assert next_first_condition(["CC"]) == "EC"
    assert next_first_condition(["EC", "EC", "CC"]) == "CC"
    assert next_first_condition(["CC", None, "CC", "EC"]) == "EC", "unassigned participants do not count"
    assert order_for("EC") == ("EC", "CC")
    with pytest.raises(ValueError, match="first condition"):
        order_for("XX")


def _data(gap: timedelta | None) -> StudyData:
    participants = (ParticipantRecord(1, "P01", "CC"), ParticipantRecord(2, "P02", "EC"))
    sessions = (
        SessionRecord(1, 1, "CC", 1, "stopped", T0),
        SessionRecord(2, 1, "EC", 2, "stopped", T0 + gap if gap is not None else None),
        SessionRecord(3, 2, "EC", 1, "stopped", T0),
    )
    full = [("ssq", "pre"), ("ssq", "post"), ("ipq", "post"), ("nasa_tlx", None)]
    responses = [ResponseRecord(i + 1, 1, ins, ph, {}, {}) for i, (ins, ph) in enumerate(full)]
    responses += [ResponseRecord(10 + i, 2, ins, ph, {}, {}) for i, (ins, ph) in enumerate(full)]
    responses.append(ResponseRecord(20, 1, "mssq", "pre", {}, {}))
    responses.append(ResponseRecord(21, 3, "ssq", "pre", {}, {}))
    return StudyData(participants, sessions, tuple(responses))


@pytest.mark.parametrize(
    ("gap", "warned"),
    [
        (timedelta(days=1, hours=23), True),
        (timedelta(hours=2), True),
        (timedelta(days=2), False),
        (None, False),
    ],
)
def test_gap_warning(gap: timedelta | None, warned: bool) -> None:
    warnings = gap_warnings(_data(gap), min_gap_days=2.0)
    assert bool(warnings) is warned
    if warned:
        (w,) = warnings
        assert w.code == "P01" and w.session_ids == (1, 2)
        assert w.gap_days == pytest.approx(gap.total_seconds() / 86400)  # type: ignore[union-attr]
        assert "less than the minimum of 2 days" in w.message


def test_completeness_lists_what_is_missing() -> None:
    rows = {r["code"]: r for r in completeness(_data(timedelta(days=2)))}
    assert rows["P01"]["complete"] is True and rows["P01"]["missing"] == []
    p2 = rows["P02"]
    assert p2["complete"] is False
    assert p2["missing_conditions"] == ["CC"]
    missing = {(m["instrument"], m["phase"]) for m in p2["missing"]}
    assert missing == {("ssq", "post"), ("ipq", None), ("nasa_tlx", None), ("mssq", None)}


def test_design_summary() -> None:
    s = design_summary(_data(timedelta(days=1)), DesignConfig(min_gap_days=2))
    # P02 ran only their first session: enrolled, but not counted in the design counts (issue 19.8)
    assert s["first_condition_counts"] == {"CC": 1, "EC": 0} and s["incomplete"] == ["P02"]
    assert s["enrolled_first_condition_counts"] == {"CC": 1, "EC": 1} and s["completed_participants"] == 1
    assert s["balanced"] is True
    assert s["next_first_condition"] == "CC" and s["next_order"] == ["CC", "EC"]
    assert len(s["gap_warnings"]) == 1 and len(s["completeness"]) == 2


def test_config_from_settings_and_validation() -> None:
    from app.core.config import load_settings

    assert load_settings().study.design.min_gap_days == 2.0
    with pytest.warns(FutureWarning, match="study.design.min_gap_days"):
        assert load_settings(study={"min_gap_days": 3.0}).study.design.min_gap_days == 3.0
    with pytest.raises(ValueError, match="min_gap_days"):
        DesignConfig(min_gap_days=-1)
