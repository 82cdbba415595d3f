"""Questionnaire scoring against hand-computed sheets, and every way a sheet is rejected."""

from __future__ import annotations

import json
from typing import Any

import pytest

from app.study.questionnaires import (
    DEFINITIONS,
    SSQ_KEYS,
    TLX_PAIRS,
    QuestionnaireError,
    instrument_definitions,
    score,
    tlx_weights,
)
from pipeline.errors import CavewalkError


def ssq(**set_: int) -> dict[str, Any]:
    return {k: set_.get(k, 0) for k in SSQ_KEYS}


def mssq(child: dict[str, Any], adult: dict[str, Any], default: Any = 0) -> dict[str, Any]:
    keys = [i.key for i in DEFINITIONS["mssq"].items]
    out = dict.fromkeys(keys, default)
    out.update({f"child_{k}": v for k, v in child.items()})
    out.update({f"adult_{k}": v for k, v in adult.items()})
    return out


IPQ_ALL_6 = {i.key: 6 for i in DEFINITIONS["ipq"].items}
TLX = {"mental": 70, "physical": 20, "temporal": 40, "performance": 30, "effort": 60, "frustration": 10}
# Always choose the first scale of the pair: weights mental 5, physical 4, ..., frustration 0.
PAIRWISE_FIRST = {f"{a}_vs_{b}": a for a, b in TLX_PAIRS}


def test_ssq_all_slight() -> None:
    # Each subscale sums 7 items of 1: N 7x9.54, O 7x7.58, D 7x13.92, total 21x3.74.
    s = score("ssq", "pre", ssq(**dict.fromkeys(SSQ_KEYS, 1)))
    assert s == pytest.approx({"nausea": 66.78, "oculomotor": 53.06, "disorientation": 97.44, "total": 78.54})


def test_ssq_items_loading_on_two_subscales() -> None:
    # general_discomfort loads on N and O, nausea on N and D, vertigo on D only:
    # N = (2 + 3) x 9.54, O = 2 x 7.58, D = (3 + 1) x 13.92, total = (5 + 2 + 4) x 3.74.
    s = score("ssq", "post", ssq(general_discomfort=2, nausea=3, vertigo=1))
    assert s == pytest.approx({"nausea": 47.7, "oculomotor": 15.16, "disorientation": 55.68, "total": 41.14})


def test_ssq_all_none_is_zero() -> None:
    assert score("ssq", "post", ssq()) == {"nausea": 0, "oculomotor": 0, "disorientation": 0, "total": 0}


def test_mssq_correction_for_types_not_experienced() -> None:
    # child: 3 + 2 over 7 experienced types -> 5 x 9 / 7; adult: nine 1s -> 9.
    ne = "not_experienced"
    sheet = mssq({"cars": 3, "buses_coaches": 2, "ships": ne, "small_boats": ne}, {}, default=0)
    sheet.update({k: 1 for k in sheet if k.startswith("adult_")})
    s = score("mssq", "pre", sheet)
    assert s == pytest.approx({"child": 45 / 7, "adult": 9.0, "total": 45 / 7 + 9}, abs=1e-4)


def test_ipq_reversed_items() -> None:
    # SP2, INV3 and REAL1 reversed: 6 -> 0.
    s = score("ipq", "post", IPQ_ALL_6)
    assert s == pytest.approx({"G1": 6.0, "SP": 24 / 5, "INV": 18 / 4, "REAL": 18 / 4})
    s = score("ipq", "post", {k: 0 for k in IPQ_ALL_6})
    assert s == pytest.approx({"G1": 0.0, "SP": 6 / 5, "INV": 6 / 4, "REAL": 6 / 4})


def test_tlx_raw_and_weighted() -> None:
    s = score("nasa_tlx", "post", TLX)
    assert s["raw_tlx"] == pytest.approx(230 / 6, abs=1e-4)
    assert "weighted_tlx" not in s, "weighted TLX only with the pairwise choices"
    assert s["mental"] == 70 and s["frustration"] == 10
    w = score("nasa_tlx", "post", TLX, PAIRWISE_FIRST)
    # (5x70 + 4x20 + 3x40 + 2x30 + 1x60 + 0x10) / 15
    assert w["weighted_tlx"] == pytest.approx(670 / 15, abs=1e-4)
    assert w["raw_tlx"] == s["raw_tlx"]


def test_tlx_weights_sum_to_15() -> None:
    weights = tlx_weights(PAIRWISE_FIRST)
    assert weights == {
        "mental": 5,
        "physical": 4,
        "temporal": 3,
        "performance": 2,
        "effort": 1,
        "frustration": 0,
    }


def _bad_pairwise(**change: Any) -> dict[str, Any]:
    p: dict[str, Any] = dict(PAIRWISE_FIRST)
    for k, v in change.items():
        if v is None:
            p.pop(k)
        else:
            p[k] = v
    return p


BAD: list[tuple[str, str | None, dict[str, Any], dict[str, Any] | None, str, str]] = [
    ("ssq", "pre", ssq(headache=4), None, "headache", r"4 is not on the scale 0-3"),
    ("ssq", "pre", ssq(headache=-1), None, "headache", r"not on the scale"),
    ("ssq", "pre", {**ssq(), "fatigue": "2"}, None, "fatigue", r"expected a whole number"),
    ("ssq", "pre", {**ssq(), "fatigue": 1.5}, None, "fatigue", r"expected a whole number"),
    ("ssq", "pre", {**ssq(), "fatigue": 1.0}, None, "fatigue", r"expected a whole number"),
    ("ssq", "pre", {**ssq(), "fatigue": True}, None, "fatigue", r"expected a whole number"),
    ("ssq", "pre", {k: 0 for k in SSQ_KEYS if k != "burping"}, None, "burping", r"1 of 16 items not"),
    ("ssq", "pre", {**ssq(), "hunger": 1}, None, "hunger", r"unknown item"),
    ("ssq", None, ssq(), None, "phase", r"phase is required and must be pre or post, got none"),
    ("ssq", "during", ssq(), None, "phase", r"phase is required"),
    ("ssq", "post", ssq(), PAIRWISE_FIRST, "pairwise", r"nasa_tlx only"),
    ("vrsq", "pre", ssq(), None, "instrument", r"unknown instrument"),
    ("mssq", "pre", mssq({"cars": 4}, {}), None, "child_cars", r"not on the scale"),
    ("mssq", "pre", mssq({"cars": "never"}, {}), None, "child_cars", r"not_experienced"),
    ("mssq", "pre", mssq({}, {}, default="not_experienced"), None, "child_cars", r"cannot be scored"),
    ("mssq", "post", mssq({}, {}), None, "phase", r"phase"),
    ("ipq", "post", {**IPQ_ALL_6, "SP3": 7}, None, "SP3", r"not on the scale 0-6"),
    ("ipq", "pre", IPQ_ALL_6, None, "phase", r"phase"),
    ("ipq", None, IPQ_ALL_6, None, "phase", r"must be post, got none"),
    ("ipq", "post", {k: v for k, v in IPQ_ALL_6.items() if k != "REAL4"}, None, "REAL4", r"not answered"),
    ("nasa_tlx", "post", {**TLX, "effort": 101}, None, "effort", r"not on the scale 0-100"),
    ("nasa_tlx", "post", {**TLX, "stress": 5}, None, "stress", r"unknown item"),
    ("nasa_tlx", "post", TLX, _bad_pairwise(mental_vs_effort=None), "mental_vs_effort", r"all 15 or none"),
    ("nasa_tlx", "post", TLX, _bad_pairwise(mental_vs_effort="physical"), "mental_vs_effort", r"expected"),
    (
        "nasa_tlx",
        "post",
        TLX,
        _bad_pairwise(effort_vs_mental="effort"),
        "effort_vs_mental",
        r"unknown pairwise",
    ),
]


def wording(instrument: str, key: str) -> str | None:
    """What the form shows for an item key: the start of its text (None for a field or an unknown key)."""
    d = DEFINITIONS.get(instrument)
    item = next((i for i in d.items if i.key == key), None) if d else None
    return item.text[:40] if item is not None else None


@pytest.mark.parametrize(
    ("instrument", "phase", "answers", "pairwise", "item", "match"),
    BAD,
    ids=[f"{b[0]}-{b[4]}-{i}" for i, b in enumerate(BAD)],
)
def test_rejected_sheet_names_the_item(
    instrument: str,
    phase: str | None,
    answers: dict[str, Any],
    pairwise: dict[str, Any] | None,
    item: str,
    match: str,
) -> None:
    before = json.dumps(answers, sort_keys=True)
    with pytest.raises(QuestionnaireError, match=match) as info:
        score(instrument, phase, answers, pairwise)
    assert info.value.item == item and item in info.value.items
    text = wording(instrument, item)
    if text is not None:
        assert text in str(info.value), "the message names the item in the instrument's own wording"
    elif item not in ("phase", "pairwise", "instrument") and "_vs_" not in item:
        assert item in str(info.value), "an unknown key is named as it was sent"
    assert isinstance(info.value, ValueError) and isinstance(info.value, CavewalkError)
    assert json.dumps(answers, sort_keys=True) == before, "scoring leaves the answers unchanged"


def test_every_missing_item_is_named_at_once_in_the_instruments_wording() -> None:
    """Issue 19.6: not one missing item at a time by internal key."""
    sheet = {k: 0 for k in SSQ_KEYS if k not in ("sweating", "burping", "vertigo")}
    with pytest.raises(QuestionnaireError) as info:
        score("ssq", "pre", sheet)
    assert info.value.items == ("sweating", "vertigo", "burping"), "in the form's order"
    msg = str(info.value)
    assert "3 of 16 items not answered" in msg
    assert "7. “Sweating”" in msg and "14. “Vertigo”" in msg and "16. “Burping”" in msg
    assert "sweating" not in msg, "no internal keys"


def test_some_pairwise_comparisons_are_refused_naming_all_missing() -> None:
    three = dict(list(PAIRWISE_FIRST.items())[:3])
    with pytest.raises(QuestionnaireError, match="answer all 15 or none") as info:
        score("nasa_tlx", "post", TLX, three)
    assert len(info.value.items) == 12
    assert "Temporal Demand or Frustration" in str(info.value)
    assert "weighted_tlx" not in score("nasa_tlx", "post", TLX, None), "none is fine: raw TLX only"


@pytest.mark.parametrize(
    ("instrument", "phase", "answers", "pairwise"),
    [
        ("ssq", "pre", ssq(), None),
        ("mssq", "pre", mssq({"cars": "not_experienced"}, {}), None),
        ("ipq", "post", IPQ_ALL_6, None),
        ("nasa_tlx", "post", {**TLX, "effort": 100}, PAIRWISE_FIRST),
    ],
)
def test_accepted_sheets(instrument: str, phase: str | None, answers: dict[str, Any], pairwise: Any) -> None:
    scores = score(instrument, phase, answers, pairwise)
    assert set(scores) <= set(DEFINITIONS[instrument].score_keys)
    assert all(isinstance(v, float | int) for v in scores.values())


def test_definitions_are_json_and_complete() -> None:
    defs = json.loads(json.dumps(instrument_definitions()))
    assert set(defs) == {"ssq", "mssq", "ipq", "nasa_tlx"}
    assert [i["key"] for i in defs["ssq"]["items"]] == list(SSQ_KEYS)
    assert all(i["min"] == 0 and i["max"] == 3 for i in defs["ssq"]["items"])
    assert len(defs["mssq"]["items"]) == 18 and defs["mssq"]["items"][0]["allow"] == ["not_experienced"]
    assert len(defs["ipq"]["items"]) == 14 and defs["ipq"]["items"][0]["anchors"] == [
        "not at all",
        "very much",
    ]
    assert len(defs["nasa_tlx"]["pairs"]) == 15
    assert defs["ssq"]["phases"] == ["pre", "post"]
