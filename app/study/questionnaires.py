"""The study's questionnaires: their items, wording and anchors, and their published scoring.

- SSQ, Simulator Sickness Questionnaire (Kennedy, Lane, Berbaum & Lilienthal 1993): 16 symptoms
  rated 0-3; Nausea, Oculomotor and Disorientation are raw sums over the standard item mapping
  (some symptoms load on two subscales) times 9.54, 7.58 and 13.92; Total is the sum of the three
  raw sums times 3.74. Filled in before (``pre``) and after (``post``) each session.
- MSSQ-short, Motion Sickness Susceptibility Questionnaire short form (Golding 2006): 9 types of
  transport or motion, rated 0-3 or ``"not_experienced"`` for childhood (before 12) and for the
  last 10 years; each section's score is ``sum x 9 / (9 - types not experienced)``, total = A + B.
- IPQ, igroup presence questionnaire (Schubert, Friedmann & Regenbrecht 2001): 14 items on a
  7-point scale 0-6; SP2, INV3 and REAL1 are reversed (6 - x); scores are G1 and the means of
  SP, INV and REAL.
- NASA-TLX (Hart & Staveland 1988): six scales 0-100; raw TLX is their mean; with the 15 pairwise
  comparisons, each scale's weight is how often it was chosen and the weighted TLX is
  ``sum(weight x rating) / 15``.

:func:`score` is what the API calls on submission; :class:`QuestionnaireError` names the item.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from itertools import combinations
from typing import Any, Final, Literal

from pipeline.errors import InputError

Instrument = Literal["ssq", "mssq", "ipq", "nasa_tlx"]
INSTRUMENTS: Final[tuple[str, ...]] = ("ssq", "mssq", "ipq", "nasa_tlx")
PHASES: Final[tuple[str, ...]] = ("pre", "post")
NOT_EXPERIENCED: Final = "not_experienced"


class QuestionnaireError(InputError):
    """An answer sheet that cannot be scored.

    item: the first offending item key (or field); items: every offending key, in the form's order
    (the form marks them all at once). The message names the items in the instrument's wording.
    """

    def __init__(self, item: str, message: str, items: tuple[str, ...] = ()) -> None:
        super().__init__(message)
        self.item = item
        self.items = items or (item,)


@dataclass(frozen=True, slots=True)
class Item:
    """One question: its key, the instrument's wording, the anchors and the integer range."""

    key: str
    text: str
    anchors: tuple[str, ...]
    min: int
    max: int
    reversed: bool = False
    allow: tuple[str, ...] = ()  # accepted non-numeric answers (MSSQ's "not_experienced")

    def __post_init__(self) -> None:
        if self.min >= self.max:
            raise ValueError(f"item {self.key}: expected min < max, got {self.min}, {self.max}")
        if len(self.anchors) < 2:
            raise ValueError(f"item {self.key}: expected at least two anchors, got {self.anchors}")


@dataclass(frozen=True, slots=True)
class Definition:
    """An instrument: title, instructions, items, the phases it is filled in and its score keys."""

    name: str
    title: str
    instructions: str
    items: tuple[Item, ...]
    phases: tuple[str | None, ...]
    score_keys: tuple[str, ...]
    pairs: tuple[tuple[str, str], ...] = field(default=())

    def __post_init__(self) -> None:
        keys = [i.key for i in self.items]
        if len(set(keys)) != len(keys):
            raise ValueError(f"{self.name}: item keys must be unique, got {keys}")

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(i.key for i in self.items)


# --- SSQ -------------------------------------------------------------------------------------
_SSQ_ANCHORS = ("None", "Slight", "Moderate", "Severe")
_SSQ_ITEMS: tuple[tuple[str, str], ...] = (
    ("general_discomfort", "General discomfort"),
    ("fatigue", "Fatigue"),
    ("headache", "Headache"),
    ("eye_strain", "Eye strain"),
    ("difficulty_focusing", "Difficulty focusing"),
    ("increased_salivation", "Increased salivation"),
    ("sweating", "Sweating"),
    ("nausea", "Nausea"),
    ("difficulty_concentrating", "Difficulty concentrating"),
    ("fullness_of_head", "Fullness of head"),
    ("blurred_vision", "Blurred vision"),
    ("dizzy_eyes_open", "Dizzy (eyes open)"),
    ("dizzy_eyes_closed", "Dizzy (eyes closed)"),
    ("vertigo", "Vertigo"),
    ("stomach_awareness", "Stomach awareness"),
    ("burping", "Burping"),
)
SSQ_KEYS: Final[tuple[str, ...]] = tuple(k for k, _ in _SSQ_ITEMS)
#: Kennedy et al. (1993), table of symptom loadings: the symptoms summed for each subscale.
SSQ_SUBSCALES: Final[dict[str, tuple[str, ...]]] = {
    "nausea": (
        "general_discomfort",
        "increased_salivation",
        "sweating",
        "nausea",
        "difficulty_concentrating",
        "stomach_awareness",
        "burping",
    ),
    "oculomotor": (
        "general_discomfort",
        "fatigue",
        "headache",
        "eye_strain",
        "difficulty_focusing",
        "difficulty_concentrating",
        "blurred_vision",
    ),
    "disorientation": (
        "difficulty_focusing",
        "nausea",
        "fullness_of_head",
        "blurred_vision",
        "dizzy_eyes_open",
        "dizzy_eyes_closed",
        "vertigo",
    ),
}
SSQ_WEIGHTS: Final[dict[str, float]] = {"nausea": 9.54, "oculomotor": 7.58, "disorientation": 13.92}
SSQ_TOTAL_WEIGHT: Final = 3.74

# --- MSSQ-short ------------------------------------------------------------------------------
MSSQ_TYPES: Final[tuple[tuple[str, str], ...]] = (
    ("cars", "Cars"),
    ("buses_coaches", "Buses or coaches"),
    ("trains", "Trains"),
    ("aircraft", "Aircraft"),
    ("small_boats", "Small boats"),
    ("ships", "Ships, e.g. channel ferries"),
    ("swings", "Swings in playgrounds"),
    ("roundabouts", "Roundabouts in playgrounds"),
    ("funfair_rides", "Big dippers, funfair rides"),
)
MSSQ_SECTIONS: Final[dict[str, str]] = {
    "child": "Your childhood experience only (before 12 years of age)",
    "adult": "Your experience over the last 10 years (approximately)",
}
_MSSQ_ANCHORS = ("Never felt sick", "Rarely felt sick", "Sometimes felt sick", "Frequently felt sick")

# --- IPQ -------------------------------------------------------------------------------------
_FULLY = ("fully disagree", "fully agree")
_IPQ_ITEMS: tuple[tuple[str, str, tuple[str, str], bool], ...] = (
    (
        "G1",
        'In the computer generated world I had a sense of "being there".',
        ("not at all", "very much"),
        False,
    ),
    ("SP1", "Somehow I felt that the virtual world surrounded me.", _FULLY, False),
    ("SP2", "I felt like I was just perceiving pictures.", _FULLY, True),
    ("SP3", "I did not feel present in the virtual space.", ("did not feel", "felt present"), False),
    (
        "SP4",
        "I had a sense of acting in the virtual space, rather than operating something from outside.",
        _FULLY,
        False,
    ),
    ("SP5", "I felt present in the virtual space.", _FULLY, False),
    (
        "INV1",
        "How aware were you of the real world surrounding while navigating in the virtual world? "
        "(i.e. sounds, room temperature, other people, etc.)",
        ("extremely aware", "not aware at all"),
        False,
    ),
    ("INV2", "I was not aware of my real environment.", _FULLY, False),
    ("INV3", "I still paid attention to the real environment.", _FULLY, True),
    ("INV4", "I was completely captivated by the virtual world.", _FULLY, False),
    ("REAL1", "How real did the virtual world seem to you?", ("completely real", "not real at all"), True),
    (
        "REAL2",
        "How much did your experience in the virtual environment seem consistent with your real world "
        "experience?",
        ("not consistent", "very consistent"),
        False,
    ),
    (
        "REAL3",
        "How real did the virtual world seem to you?",
        ("about as real as an imagined world", "indistinguishable from the real world"),
        False,
    ),
    ("REAL4", "The virtual world seemed more realistic than the real world.", _FULLY, False),
)
IPQ_SUBSCALES: Final[dict[str, tuple[str, ...]]] = {
    "G1": ("G1",),
    "SP": ("SP1", "SP2", "SP3", "SP4", "SP5"),
    "INV": ("INV1", "INV2", "INV3", "INV4"),
    "REAL": ("REAL1", "REAL2", "REAL3", "REAL4"),
}

# --- NASA-TLX --------------------------------------------------------------------------------
_TLX_ITEMS: tuple[tuple[str, str, tuple[str, str]], ...] = (
    ("mental", "Mental Demand: How mentally demanding was the task?", ("Very Low", "Very High")),
    ("physical", "Physical Demand: How physically demanding was the task?", ("Very Low", "Very High")),
    (
        "temporal",
        "Temporal Demand: How hurried or rushed was the pace of the task?",
        ("Very Low", "Very High"),
    ),
    (
        "performance",
        "Performance: How successful were you in accomplishing what you were asked to do?",
        ("Perfect", "Failure"),
    ),
    (
        "effort",
        "Effort: How hard did you have to work to accomplish your level of performance?",
        ("Very Low", "Very High"),
    ),
    (
        "frustration",
        "Frustration: How insecure, discouraged, irritated, stressed, and annoyed were you?",
        ("Very Low", "Very High"),
    ),
)
TLX_SCALES: Final[tuple[str, ...]] = tuple(k for k, _, _ in _TLX_ITEMS)
#: The 15 pairwise comparisons, keyed ``"<a>_vs_<b>"`` in the scales' order.
TLX_PAIRS: Final[tuple[tuple[str, str], ...]] = tuple(combinations(TLX_SCALES, 2))


def _pair_key(a: str, b: str) -> str:
    return f"{a}_vs_{b}"


DEFINITIONS: Final[dict[str, Definition]] = {
    "ssq": Definition(
        name="ssq",
        title="Simulator Sickness Questionnaire (SSQ)",
        instructions="Select how much each symptom below is affecting you right now.",
        items=tuple(Item(k, t, _SSQ_ANCHORS, 0, 3) for k, t in _SSQ_ITEMS),
        phases=("pre", "post"),
        score_keys=("nausea", "oculomotor", "disorientation", "total"),
    ),
    "mssq": Definition(
        name="mssq",
        title="Motion Sickness Susceptibility Questionnaire, short form (MSSQ-short)",
        instructions=(
            "For each of the following types of transport or motion, indicate how often you felt sick "
            "or nauseated (e.g. nausea, could include vomiting). Choose 'not experienced' if you never "
            "travelled on or experienced it."
        ),
        items=tuple(
            Item(
                f"{section}_{key}",
                f"{text} — {MSSQ_SECTIONS[section]}",
                _MSSQ_ANCHORS,
                0,
                3,
                allow=(NOT_EXPERIENCED,),
            )
            for section in MSSQ_SECTIONS
            for key, text in MSSQ_TYPES
        ),
        phases=("pre",),
        score_keys=("child", "adult", "total"),
    ),
    "ipq": Definition(
        name="ipq",
        title="igroup presence questionnaire (IPQ)",
        instructions="Rate each statement about the virtual world you just experienced (7-point scale).",
        items=tuple(Item(k, t, a, 0, 6, reversed=r) for k, t, a, r in _IPQ_ITEMS),
        phases=("post",),
        score_keys=("G1", "SP", "INV", "REAL"),
    ),
    "nasa_tlx": Definition(
        name="nasa_tlx",
        title="NASA Task Load Index (NASA-TLX)",
        instructions=(
            "Rate the task you just performed on each scale (0-100). Then, for each pair, choose the "
            "scale that contributed more to the workload."
        ),
        items=tuple(Item(k, t, a, 0, 100) for k, t, a in _TLX_ITEMS),
        phases=("post",),
        score_keys=("raw_tlx", "weighted_tlx", *TLX_SCALES),
        pairs=TLX_PAIRS,
    ),
}


def instrument_definitions() -> dict[str, Any]:
    """Every instrument as JSON-able data for the questionnaire form."""
    out: dict[str, Any] = {}
    for name, d in DEFINITIONS.items():
        out[name] = {
            "name": name,
            "title": d.title,
            "instructions": d.instructions,
            "phases": list(d.phases),
            "score_keys": list(d.score_keys),
            "items": [
                {
                    "key": i.key,
                    "text": i.text,
                    "anchors": list(i.anchors),
                    "min": i.min,
                    "max": i.max,
                    "allow": list(i.allow),
                }
                for i in d.items
            ],
            "pairs": [{"key": _pair_key(a, b), "options": [a, b]} for a, b in d.pairs],
        }
    return out


# --- validation ------------------------------------------------------------------------------

SHORT_NAMES: Final[dict[str, str]] = {"ssq": "SSQ", "mssq": "MSSQ", "ipq": "IPQ", "nasa_tlx": "NASA-TLX"}
TLX_SCALE_NAMES: Final[dict[str, str]] = {k: t.split(":", 1)[0] for k, t, _ in _TLX_ITEMS}


def _wording(d: Definition, item: Item) -> str:
    """How the form shows an item: its number and (up to 70 characters of) its text."""
    text = item.text if len(item.text) <= 70 else item.text[:67].rstrip() + "…"
    return f"{d.keys.index(item.key) + 1}. “{text}”"


def _value(item: Item, raw: object) -> int | str | None:
    """The answer as an integer in range, None for an allowed non-numeric answer, or a problem (str)."""
    if isinstance(raw, str) and raw in item.allow:
        return None
    allowed = f" or {', '.join(repr(a) for a in item.allow)}" if item.allow else ""
    if isinstance(raw, bool) or not isinstance(raw, int):
        return f"expected a whole number {item.min}-{item.max}{allowed}, got {raw!r}"
    if not item.min <= raw <= item.max:
        return f"{raw} is not on the scale {item.min}-{item.max}"
    return int(raw)


def _answers(d: Definition, answers: Mapping[str, object]) -> dict[str, int | None]:
    if not isinstance(answers, Mapping):
        raise QuestionnaireError("answers", f"answers must be an object, got {type(answers).__name__}")
    name = SHORT_NAMES[d.name]
    known = set(d.keys)
    unknown = [str(k) for k in answers if k not in known]
    if unknown:
        raise QuestionnaireError(
            unknown[0],
            f"unknown item{'s' if len(unknown) > 1 else ''} {', '.join(repr(k) for k in unknown)} for {name}",
            tuple(unknown),
        )
    out: dict[str, int | None] = {}
    missing: list[Item] = []
    bad: list[tuple[Item, str]] = []
    for item in d.items:
        if item.key not in answers:
            missing.append(item)
            continue
        v = _value(item, answers[item.key])
        if isinstance(v, str):
            bad.append((item, v))
        else:
            out[item.key] = v
    if missing or bad:
        parts = []
        if missing:
            parts.append(
                f"{len(missing)} of {len(d.items)} items not answered: "
                + "; ".join(_wording(d, i) for i in missing)
            )
        if bad:
            parts.append("; ".join(f"{_wording(d, i)}: {problem}" for i, problem in bad))
        keys = tuple(i.key for i in d.items if i in missing or any(i is b for b, _ in bad))
        raise QuestionnaireError(keys[0], f"{name}: " + ". ".join(parts), keys)
    return out


def _check_phase(d: Definition, phase: str | None) -> None:
    if phase not in d.phases:
        expected = " or ".join(str(p) for p in d.phases)
        got = "none" if phase is None else repr(phase)
        raise QuestionnaireError(
            "phase", f"{SHORT_NAMES[d.name]}: the phase is required and must be {expected}, got {got}"
        )


# --- scoring ---------------------------------------------------------------------------------


def score_ssq(values: Mapping[str, int]) -> dict[str, float]:
    raw = {name: sum(values[k] for k in keys) for name, keys in SSQ_SUBSCALES.items()}
    out = {name: raw[name] * SSQ_WEIGHTS[name] for name in SSQ_SUBSCALES}
    out["total"] = sum(raw.values()) * SSQ_TOTAL_WEIGHT
    return {k: round(v, 4) for k, v in out.items()}


def score_mssq(values: Mapping[str, int | None]) -> dict[str, float]:
    out: dict[str, float] = {}
    for section, label in MSSQ_SECTIONS.items():
        answered = [values[f"{section}_{key}"] for key, _ in MSSQ_TYPES]
        rated = [v for v in answered if v is not None]
        if not rated:
            items = [i for i in DEFINITIONS["mssq"].items if i.key.startswith(f"{section}_")]
            raise QuestionnaireError(
                items[0].key,
                f"MSSQ: {label}: all {len(items)} types are 'not experienced' (from “{items[0].text}” "
                f"to “{items[-1].text}”); the section cannot be scored",
                tuple(i.key for i in items),
            )
        not_experienced = len(answered) - len(rated)
        out[section] = sum(rated) * len(MSSQ_TYPES) / (len(MSSQ_TYPES) - not_experienced)
    out["total"] = out["child"] + out["adult"]
    return {k: round(v, 4) for k, v in out.items()}


def score_ipq(values: Mapping[str, int]) -> dict[str, float]:
    reversed_keys = {i.key for i in DEFINITIONS["ipq"].items if i.reversed}
    adjusted = {k: (6 - v if k in reversed_keys else v) for k, v in values.items()}
    return {
        name: round(sum(adjusted[k] for k in keys) / len(keys), 4) for name, keys in IPQ_SUBSCALES.items()
    }


def tlx_weights(pairwise: Mapping[str, object]) -> dict[str, int]:
    """How often each scale was chosen in the 15 comparisons (the weights sum to 15)."""
    if not isinstance(pairwise, Mapping):
        raise QuestionnaireError("pairwise", f"pairwise must be an object, got {type(pairwise).__name__}")
    expected = {_pair_key(a, b): (a, b) for a, b in TLX_PAIRS}
    unknown = [str(k) for k in pairwise if k not in expected]
    if unknown:
        raise QuestionnaireError(
            unknown[0],
            f"unknown pairwise comparison(s) {', '.join(map(repr, unknown))}; expected keys like "
            f"'mental_vs_physical'",
            tuple(unknown),
        )

    def names(key: str) -> str:
        a, b = expected[key]
        return f"{TLX_SCALE_NAMES[a]} or {TLX_SCALE_NAMES[b]}"

    missing = [k for k in expected if k not in pairwise]
    if missing:
        raise QuestionnaireError(
            missing[0],
            f"NASA-TLX pairwise comparisons: answer all 15 or none (the weighted score needs all 15); "
            f"{len(missing)} not answered: " + "; ".join(names(k) for k in missing),
            tuple(missing),
        )
    bad = [k for k, pair in expected.items() if pairwise[k] not in pair]
    if bad:
        raise QuestionnaireError(
            bad[0],
            "NASA-TLX pairwise comparisons: "
            + "; ".join(f"{names(k)}: expected {expected[k][0]!r} or {expected[k][1]!r}, got "
                        f"{pairwise[k]!r}" for k in bad),
            tuple(bad),
        )
    weights = dict.fromkeys(TLX_SCALES, 0)
    for key in expected:
        weights[str(pairwise[key])] += 1
    return weights


def score_tlx(values: Mapping[str, int], pairwise: Mapping[str, object] | None) -> dict[str, float]:
    out: dict[str, float] = {k: float(values[k]) for k in TLX_SCALES}
    out["raw_tlx"] = round(sum(values[k] for k in TLX_SCALES) / len(TLX_SCALES), 4)
    if pairwise is not None:
        w = tlx_weights(pairwise)
        out["weighted_tlx"] = round(sum(w[k] * values[k] for k in TLX_SCALES) / len(TLX_PAIRS), 4)
    return out


def score(
    instrument: str,
    phase: str | None,
    answers: Mapping[str, object],
    pairwise: Mapping[str, object] | None = None,
) -> dict[str, float]:
    """Validate one answer sheet and return its scores (see the module docstring).

    Raises :class:`QuestionnaireError` (a ``ValueError``) naming the item for an unknown
    instrument, a wrong phase, an unknown, missing or out-of-range item, or bad pairwise choices.
    """
    if instrument not in DEFINITIONS:
        raise QuestionnaireError(
            "instrument", f"unknown instrument {instrument!r}; expected one of {list(INSTRUMENTS)}"
        )
    d = DEFINITIONS[instrument]
    _check_phase(d, phase)
    values = _answers(d, answers)
    if pairwise is not None and instrument != "nasa_tlx":
        raise QuestionnaireError("pairwise", f"{instrument}: pairwise choices belong to nasa_tlx only")
    if instrument == "mssq":
        return score_mssq(values)
    numeric = {k: v for k, v in values.items() if v is not None}
    if instrument == "ssq":
        return score_ssq(numeric)
    if instrument == "ipq":
        return score_ipq(numeric)
    return score_tlx(numeric, pairwise)
