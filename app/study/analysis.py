"""The within-subject analysis of the study, as the paper ran it in SPSS.

Per measure (SSQ after the session and its change from before, IPQ, NASA-TLX): descriptives per
condition; Shapiro-Wilk on the paired differences (EC - CC); when they look normal the paired
t-test and the repeated-measures ANOVA F(1, n-1) with partial eta squared (sphericity is trivially
met with two levels; Mauchly's test and the Greenhouse-Geisser correction are applied for designs
with more levels); otherwise the Wilcoxon signed-rank test with Z and r = Z / sqrt(n); Cohen's
d_z for paired data with its exact 95 % confidence interval (noncentral t, as R's effectsize and
MBESS compute it: it excludes 0 exactly when the paired t-test's p < .05) and the paper's six-level
label. Below ``normality_min_n`` pairs Shapiro-Wilk has too little power to judge normality, which
each measure then says. The p-values of all tested measures are corrected for multiple comparisons
(Holm by default, or Bonferroni), and the table says which.

Only what is in use enters: excluded participants, sessions and entries, and entries replaced by a
correction, are left out and listed; each measure names the entries (ids) it used.

Statistics come from scipy and pingouin. Wilcoxon p-values follow R's ``wilcox.test``: zero
differences are dropped ("wilcox" zero method); exact p without ties or zeros for n < 50,
otherwise the tie-corrected normal approximation with continuity correction. Z is the
tie-corrected normal deviate without continuity correction (as SPSS reports it).
"""

from __future__ import annotations

import logging
import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from app.study.config import AnalysisConfig
from app.study.data import CONDITIONS, ResponseRecord, StudyData

log = logging.getLogger(__name__)

#: measure -> (instrument, phase or None for any, score key). ``ssq_total_delta`` is post - pre.
MEASURES: dict[str, tuple[str, str | None, str]] = {
    "ssq_total_post": ("ssq", "post", "total"),
    "ssq_nausea_post": ("ssq", "post", "nausea"),
    "ssq_oculomotor_post": ("ssq", "post", "oculomotor"),
    "ssq_disorientation_post": ("ssq", "post", "disorientation"),
    "ssq_total_delta": ("ssq", "post-pre", "total"),
    "ipq_G1": ("ipq", None, "G1"),
    "ipq_SP": ("ipq", None, "SP"),
    "ipq_INV": ("ipq", None, "INV"),
    "ipq_REAL": ("ipq", None, "REAL"),
    "tlx_raw": ("nasa_tlx", None, "raw_tlx"),
    "tlx_weighted": ("nasa_tlx", None, "weighted_tlx"),
    "tlx_mental": ("nasa_tlx", None, "mental"),
    "tlx_physical": ("nasa_tlx", None, "physical"),
    "tlx_temporal": ("nasa_tlx", None, "temporal"),
    "tlx_performance": ("nasa_tlx", None, "performance"),
    "tlx_effort": ("nasa_tlx", None, "effort"),
    "tlx_frustration": ("nasa_tlx", None, "frustration"),
}
MIN_N = 3
#: The paper's six levels of |d| (upper bounds): negligible < 0.2 <= very small < 0.5 <= small
#: < 0.8 <= medium < 1.2 <= large < 2.0 <= very large.
EFFECT_LEVELS: tuple[tuple[float, str], ...] = (
    (0.2, "negligible"),
    (0.5, "very small"),
    (0.8, "small"),
    (1.2, "medium"),
    (2.0, "large"),
    (math.inf, "very large"),
)
SPHERICITY_TWO_LEVELS = (
    "sphericity is trivially met with two levels (a single difference score): "
    "Mauchly's test and the Greenhouse-Geisser correction do not apply"
)


CORRECTION_NAMES: dict[str, str] = {"holm": "Holm", "bonferroni": "Bonferroni", "none": "no correction"}


def adjust_p(p_values: Sequence[float], method: str) -> list[float]:
    """Family-wise adjusted p-values (as R's ``p.adjust``): Holm's step-down, Bonferroni, or none."""
    p = np.asarray(p_values, dtype=float)
    m = p.size
    if method == "none" or m == 0:
        return [float(v) for v in p]
    if method == "bonferroni":
        return [float(v) for v in np.minimum(1.0, p * m)]
    if method != "holm":
        raise ValueError(f"unknown correction {method!r}")
    order = np.argsort(p, kind="stable")
    adjusted = np.empty(m)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p[i]))
        adjusted[i] = running
    return [float(v) for v in adjusted]


def _num(x: Any) -> float | None:
    """A finite float, or None (JSON has no NaN)."""
    if x is None:
        return None
    v = float(x)
    return v if math.isfinite(v) else None


def describe(values: ArrayLike) -> dict[str, float | int | None]:
    """n, mean, SD (n - 1), median, quartiles and IQR."""
    a = np.asarray(values, dtype=float)
    if a.size == 0:
        return {"n": 0, "mean": None, "sd": None, "median": None, "q1": None, "q3": None, "iqr": None}
    q1, med, q3 = np.percentile(a, [25, 50, 75])
    return {
        "n": int(a.size),
        "mean": _num(np.mean(a)),
        "sd": _num(np.std(a, ddof=1)) if a.size > 1 else None,
        "median": _num(med),
        "q1": _num(q1),
        "q3": _num(q3),
        "iqr": _num(q3 - q1),
    }


def effect_label(d: float | None) -> str | None:
    """The paper's label of an effect size |d| (see :data:`EFFECT_LEVELS`)."""
    if d is None or not math.isfinite(d):
        return None
    for upper, label in EFFECT_LEVELS:
        if abs(d) < upper:
            return label
    return EFFECT_LEVELS[-1][1]


def is_constant(values: NDArray[np.float64]) -> bool:
    """All values equal, up to floating-point noise (scores like 7 x 9.54 - 3 x 9.54)."""
    return values.size == 0 or float(np.ptp(values)) <= 1e-9 * max(1.0, float(np.max(np.abs(values))))


def shapiro(diff: NDArray[np.float64]) -> tuple[float | None, float | None]:
    from scipy.stats import shapiro as _shapiro

    if diff.size < MIN_N or is_constant(diff):
        return None, None  # undefined for fewer than 3 values or constant data
    res = _shapiro(diff)
    return _num(res.statistic), _num(res.pvalue)


def paired_t(x: NDArray[np.float64], y: NDArray[np.float64]) -> dict[str, Any]:
    """Paired t-test of x - y (pingouin)."""
    import pingouin as pg

    with warnings.catch_warnings():  # pandas/pingouin deprecation chatter a user cannot act on
        warnings.simplefilter("ignore")
        row = pg.ttest(x, y, paired=True).iloc[0]
    return {"statistic": _num(row["T"]), "df": int(row["dof"]), "p": _num(row["p_val"])}


def wilcoxon(x: NDArray[np.float64], y: NDArray[np.float64]) -> dict[str, Any] | None:
    """Wilcoxon signed-rank test of x - y (scipy), R's conventions for p, SPSS's Z; None if all zero."""
    from scipy.stats import wilcoxon as _wilcoxon

    diff = x - y
    nonzero = diff[diff != 0]
    n = int(nonzero.size)
    if n == 0:
        return None
    ties = np.unique(np.abs(nonzero)).size < n
    zeros = n < diff.size
    exact = n < 50 and not ties and not zeros
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # scipy warns about ties / small samples under the approximation
        res = _wilcoxon(
            x, y, zero_method="wilcox", correction=not exact, method="exact" if exact else "asymptotic"
        )
        v = _wilcoxon(x, y, zero_method="wilcox", alternative="greater", method="asymptotic").statistic
        z = _wilcoxon(x, y, zero_method="wilcox", correction=False, method="asymptotic").zstatistic
    return {
        "statistic": _num(res.statistic),  # the smaller of the two rank sums (W)
        "V": _num(v),  # the sum of the positive ranks (R's V)
        "p": _num(res.pvalue),
        "z": _num(z),
        "r": _num(z / math.sqrt(n)),
        "n_nonzero": n,
        "p_method": "exact" if exact else "normal approximation, tie-corrected, continuity-corrected",
    }


def dz_interval(d: float, n: int, level: float = 0.95) -> tuple[float, float]:
    """The exact confidence interval of Cohen's d_z from n pairs: invert the noncentral t.

    t = d sqrt(n) has a noncentral t distribution with n - 1 df and noncentrality delta sqrt(n);
    the limits are the noncentralities at which the observed t is the (1 + level) / 2 and
    (1 - level) / 2 quantile, divided by sqrt(n) (Steiger & Fouladi 1997; R's effectsize and MBESS).
    """
    from scipy.optimize import brentq
    from scipy.stats import nct

    df = n - 1
    t = d * math.sqrt(n)
    upper_q, lower_q = (1 + level) / 2, (1 - level) / 2
    span = abs(t) + 10.0 + 10.0 * math.sqrt(abs(t))

    def limit(q: float) -> float:
        def f(ncp: float) -> float:
            p = float(nct.cdf(t, df, ncp))
            if not math.isfinite(p):  # far in a tail, where scipy's series gives up
                p = 0.0 if ncp > t else 1.0
            return p - q

        lo, hi = t - span, t + span
        while f(lo) < 0:
            lo -= span
        while f(hi) > 0:
            hi += span
        return float(brentq(f, lo, hi, xtol=1e-12))

    return limit(upper_q) / math.sqrt(n), limit(lower_q) / math.sqrt(n)


def cohens_dz(x: NDArray[np.float64], y: NDArray[np.float64]) -> tuple[float | None, list[float] | None]:
    """Cohen's d_z of x - y (mean / SD of the differences) and its exact 95 % CI (noncentral t)."""
    diff = x - y
    if diff.size < 2 or is_constant(diff):
        return None, None
    d = float(np.mean(diff) / np.std(diff, ddof=1))
    lo, hi = dz_interval(d, int(diff.size))
    return _num(d), [lo, hi]


def rm_anova(levels: Mapping[str, ArrayLike]) -> dict[str, Any]:
    """One-way repeated-measures ANOVA over the conditions in ``levels`` (same subjects, same order).

    With more than two levels, Mauchly's test of sphericity and the Greenhouse-Geisser corrected
    p-value (pingouin); with two, sphericity holds trivially and that is said in the result.
    """
    import pandas as pd
    import pingouin as pg

    arrays = {k: np.asarray(v, dtype=float) for k, v in levels.items()}
    n = {a.size for a in arrays.values()}
    if len(arrays) < 2 or len(n) != 1:
        raise ValueError(
            f"expected >= 2 levels of equal length, got sizes { {k: a.size for k, a in arrays.items()} }"
        )
    (size,) = n
    df = pd.DataFrame(
        {
            "subject": np.tile(np.arange(size), len(arrays)),
            "condition": np.repeat(list(arrays), size),
            "value": np.concatenate(list(arrays.values())),
        }
    )
    k = len(arrays)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        table = pg.rm_anova(
            data=df,
            dv="value",
            within="condition",
            subject="subject",
            detailed=True,
            effsize="np2",
            correction=k > 2,
        )
    row = table.iloc[0]
    out: dict[str, Any] = {
        "F": _num(row["F"]),
        "df1": int(row["DF"]),
        "df2": int(table.iloc[1]["DF"]),
        "p": _num(row["p_unc"]),
        "partial_eta_sq": _num(row["np2"]),
        "levels": k,
    }
    if k == 2:
        out["sphericity"] = SPHERICITY_TWO_LEVELS
    else:
        out["mauchly_W"] = _num(row.get("W_spher"))
        out["mauchly_p"] = _num(row.get("p_spher"))
        out["sphericity_met"] = bool(row.get("sphericity"))
        out["gg_epsilon"] = _num(row.get("eps"))
        out["p_gg"] = _num(row.get("p_GG_corr"))
    return out


def paired_test(
    cc: ArrayLike, ec: ArrayLike, alpha: float = 0.05, normality_min_n: int = 10
) -> dict[str, Any]:
    """Compare the two conditions on paired values (index i = the same participant); EC - CC."""
    # Rounded to 10 decimals so that floating-point noise in differences of scores (e.g. 0.1 + 0.2
    # - 0.3) is not taken for a real difference by the zero and tie handling of the tests.
    a = np.round(np.asarray(cc, dtype=float), 10)
    b = np.round(np.asarray(ec, dtype=float), 10)
    if a.shape != b.shape or a.ndim != 1:
        raise ValueError(f"expected two 1-D arrays of equal length, got shapes {a.shape} and {b.shape}")
    dc, de = describe(a), describe(b)
    out: dict[str, Any] = {
        "n": int(a.size),
        "test": None,
        "statistic": None,
        "p": None,
        "cohens_d": None,
        "cohens_d_ci95": None,
        "effect_label": None,
        "normal": None,
        "mean_cc": dc["mean"],
        "sd_cc": dc["sd"],
        "median_cc": dc["median"],
        "iqr_cc": dc["iqr"],
        "mean_ec": de["mean"],
        "sd_ec": de["sd"],
        "median_ec": de["median"],
        "iqr_ec": de["iqr"],
        "mean_diff": _num(np.mean(b - a)) if a.size else None,
        "direction": "EC - CC",
    }
    if a.size < MIN_N:
        out["note"] = (
            f"not enough data: {a.size} participant(s) with both conditions, at least {MIN_N} needed"
        )
        return out
    diff = np.round(b - a, 10)
    w, p_sw = shapiro(diff)
    out["shapiro_w"], out["shapiro_p"] = w, p_sw
    out["normal"] = bool(p_sw is not None and p_sw > alpha)
    if a.size < normality_min_n:
        out["normality_underpowered"] = True
        out["normality_note"] = (
            f"n = {a.size}: too few pairs to judge normality (Shapiro-Wilk has little power below "
            f"n = {normality_min_n}); the test was chosen by it all the same"
        )
    d, ci = cohens_dz(b, a)
    out["cohens_d"], out["cohens_d_ci95"], out["effect_label"] = d, ci, effect_label(d)
    if np.all(diff == 0):
        out["note"] = "every paired difference is zero: no test is possible"
        return out
    wil = wilcoxon(b, a)
    out["wilcoxon"] = wil
    if not is_constant(diff):
        out["paired_t"] = paired_t(b, a)
        out["anova"] = rm_anova({"CC": a, "EC": b})
    if out["normal"]:
        out.update(test="paired_t", statistic=out["paired_t"]["statistic"], p=out["paired_t"]["p"])
        out["df"] = out["paired_t"]["df"]
    elif wil is not None:
        out.update(test="wilcoxon", statistic=wil["statistic"], p=wil["p"], z=wil["z"], r=wil["r"])
        if is_constant(diff):
            out["note"] = "every paired difference is the same: Shapiro-Wilk and the t-test are undefined"
    return out


# --- from the study records to paired values -------------------------------------------------


def _latest(responses: Sequence[ResponseRecord], instrument: str, phase: str | None) -> ResponseRecord | None:
    """The entry in use (a correction replaces the entry it corrects; duplicates are refused)."""
    match = [
        r
        for r in responses
        if r.instrument == instrument and (phase is None or r.phase == phase) and r.in_use
    ]
    return match[-1] if match else None


def session_entries(responses: Sequence[ResponseRecord], measure: str) -> tuple[float, list[int]] | None:
    """The measure's value in one session and the ids of the entries it comes from, or None."""
    instrument, phase, key = MEASURES[measure]
    if phase == "post-pre":
        post, pre = _latest(responses, instrument, "post"), _latest(responses, instrument, "pre")
        if post is None or pre is None or key not in post.scores or key not in pre.scores:
            return None
        return float(post.scores[key]) - float(pre.scores[key]), [pre.id, post.id]
    r = _latest(responses, instrument, phase)
    if r is None or key not in r.scores or r.scores[key] is None:
        return None
    return float(r.scores[key]), [r.id]


def session_value(responses: Sequence[ResponseRecord], measure: str) -> float | None:
    """The measure's value in one session (its questionnaire in use), or None."""
    found = session_entries(responses, measure)
    return None if found is None else found[0]


def condition_entries(data: StudyData, measure: str) -> dict[str, dict[str, tuple[float, list[int]]]]:
    """participant code -> condition -> (value, entry ids), from the session of that condition."""
    out: dict[str, dict[str, tuple[float, list[int]]]] = {}
    for p in data.participants:
        per: dict[str, tuple[float, list[int]]] = {}
        for s in data.sessions_of(p.id):  # ordered by id: a later session of a condition wins
            found = session_entries(data.responses_of(s.id), measure)
            if found is not None:
                per[s.condition] = found
        out[p.code] = per
    return out


def condition_values(data: StudyData, measure: str) -> dict[str, dict[str, float]]:
    """participant code -> condition -> value (from the latest session of that condition that has it)."""
    return {
        code: {c: v for c, (v, _ids) in per.items()} for code, per in condition_entries(data, measure).items()
    }


def paired_values(
    data: StudyData, measure: str
) -> tuple[list[str], NDArray[np.float64], NDArray[np.float64]]:
    """Codes and the CC and EC values of the participants who have both."""
    values = condition_values(data, measure)
    codes = [c for c, v in values.items() if all(k in v for k in CONDITIONS)]
    cc = np.array([values[c]["CC"] for c in codes], dtype=float)
    ec = np.array([values[c]["EC"] for c in codes], dtype=float)
    return codes, cc, ec


def _mssq(data: StudyData) -> dict[str, Any]:
    per: dict[str, Mapping[str, float]] = {}
    for p in data.participants:
        for s in data.sessions_of(p.id):
            r = _latest(data.responses_of(s.id), "mssq", None)
            if r is not None:
                per[p.code] = r.scores
    first = {p.code: p.first_condition for p in data.participants}
    out: dict[str, Any] = {
        "n": len(per),
        "role": "description / covariate (filled once, before the first session)",
        **{k: describe([float(v[k]) for v in per.values() if k in v]) for k in ("child", "adult", "total")},
        "total_by_first_condition": {
            c: describe([float(v["total"]) for code, v in per.items() if first[code] == c and "total" in v])
            for c in CONDITIONS
        },
        "values": {code: dict(v) for code, v in per.items()},
    }
    codes, cc, ec = paired_values(data, "ssq_total_post")
    mssq_total = np.array([float(per[c]["total"]) if c in per else np.nan for c in codes])
    keep = np.isfinite(mssq_total)
    if keep.sum() >= MIN_N and np.ptp(mssq_total[keep]) > 0 and np.ptp((ec - cc)[keep]) > 0:
        from scipy.stats import spearmanr

        rho = spearmanr(mssq_total[keep], (ec - cc)[keep])
        out["spearman_with_ssq_total_post_diff"] = {
            "rho": _num(rho.statistic),
            "p": _num(rho.pvalue),
            "n": int(keep.sum()),
        }
    return out


def analyse(data: StudyData, config: AnalysisConfig | None = None) -> dict[str, Any]:
    """The whole analysis as JSON-able data (the shape of ``GET /api/v1/analysis``)."""
    config = config or AnalysisConfig()
    exclusions = data.exclusions()
    registered = len(data.participants)
    data = data.analysed()
    reasons: dict[str, str] = {}
    for p in data.participants:
        have = {s.condition for s in data.sessions_of(p.id) if data.responses_of(s.id)}
        missing = [c for c in CONDITIONS if c not in have]
        if missing:
            reasons[p.code] = (
                "no questionnaire in any session"
                if len(missing) == 2
                else f"no data in condition {missing[0]}"
            )
    measures: dict[str, Any] = {}
    for name in MEASURES:
        entries = condition_entries(data, name)
        values = {code: {c: v for c, (v, _) in per.items()} for code, per in entries.items()}
        codes, cc, ec = paired_values(data, name)
        result = paired_test(cc, ec, config.alpha, config.normality_min_n)
        result["participants"] = codes
        result["entries"] = {code: {c: entries[code][c][1] for c in CONDITIONS} for code in codes}
        result["excluded"] = sorted(
            c for c, v in values.items() if not all(k in v for k in CONDITIONS) and c not in reasons
        )
        measures[name] = result
    tested = [name for name, m in measures.items() if m["p"] is not None]
    adjusted = adjust_p([measures[name]["p"] for name in tested], config.correction)
    for name, m in measures.items():
        m["p_adjusted"] = adjusted[tested.index(name)] if name in tested else None
        m["correction"] = config.correction
        m["significant"] = m["p_adjusted"] is not None and m["p_adjusted"] < config.alpha
    return {
        "participants": registered,
        "analysed_participants": len(data.participants),
        "excluded": sorted(reasons),
        "excluded_reasons": reasons,
        "exclusions": exclusions,
        "alpha": config.alpha,
        "correction": config.correction,
        "correction_text": (
            f"p adjusted for {len(tested)} tests ({CORRECTION_NAMES[config.correction]})"
            if config.correction != "none"
            else f"p unadjusted for {len(tested)} tests"
        ),
        "family_size": len(tested),
        "direction": "differences are EC - CC",
        "measures": measures,
        "mssq": _mssq(data),
    }
