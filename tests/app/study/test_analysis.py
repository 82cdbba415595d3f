"""The statistics against values computed independently (R outputs, textbook formulas), and the mess."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta
from typing import Any

import numpy as np
import pytest

from app.study.analysis import (
    MEASURES,
    SPHERICITY_TWO_LEVELS,
    analyse,
    cohens_dz,
    effect_label,
    paired_t,
    paired_test,
    rm_anova,
    shapiro,
    wilcoxon,
)
from app.study.data import ParticipantRecord, ResponseRecord, SessionRecord, StudyData

# R's `sleep` data: extra hours of sleep, the same 10 patients under drug 1 and drug 2.
SLEEP_1 = np.array([0.7, -1.6, -0.2, -1.2, -0.1, 3.4, 3.7, 0.8, 0.0, 2.0])
SLEEP_2 = np.array([1.9, 0.8, 1.1, 0.1, -0.1, 4.4, 5.5, 1.6, 4.6, 3.4])
# R's ?wilcox.test example (Hollander & Wolfe, depression scale before/after therapy).
HW_X = np.array([1.83, 0.50, 1.62, 2.48, 1.68, 1.88, 1.55, 3.06, 1.30])
HW_Y = np.array([0.878, 0.647, 0.598, 2.05, 1.06, 1.29, 1.06, 3.14, 1.29])
# Mice weights before/after (STHDA's paired t-test tutorial, computed there in R).
MICE_BEFORE = np.array([200.1, 190.9, 192.7, 213, 241.4, 196.9, 172.2, 185.5, 205.2, 193.7])
MICE_AFTER = np.array([392.9, 393.2, 345.1, 393, 434, 427.9, 422, 383.9, 392.3, 352.2])


def test_paired_t_matches_r_sleep() -> None:
    # R: t.test(sleep$extra[1:10], sleep$extra[11:20], paired = TRUE)
    #    t = -4.0621, df = 9, p-value = 0.002833
    r = paired_t(SLEEP_1, SLEEP_2)
    assert r["statistic"] == pytest.approx(-4.0621, abs=1e-4)
    assert r["df"] == 9
    assert r["p"] == pytest.approx(0.002833, abs=1e-6)


def test_shapiro_matches_r() -> None:
    # R: shapiro.test(sleep$extra[1:10] - sleep$extra[11:20]) -> W = 0.82987, p-value = 0.03334
    w, p = shapiro(SLEEP_1 - SLEEP_2)
    assert w == pytest.approx(0.82987, abs=1e-5) and p == pytest.approx(0.03334, abs=1e-5)
    # R: shapiro.test(before - after) (mice) -> W = 0.94536, p-value = 0.6141
    w, p = shapiro(MICE_BEFORE - MICE_AFTER)
    assert w == pytest.approx(0.94536, abs=1e-5) and p == pytest.approx(0.6141, abs=1e-4)


def test_wilcoxon_exact_matches_r() -> None:
    # R: wilcox.test(x, y, paired = TRUE) -> V = 40, p-value = 0.03906 (exact: no ties, no zeros)
    r = wilcoxon(HW_X, HW_Y)
    assert r is not None
    assert r["V"] == 40 and r["statistic"] == 5, "W = min(V, n(n+1)/2 - V) = min(40, 5)"
    assert r["p"] == pytest.approx(0.03906, abs=1e-5)
    assert r["p_method"] == "exact"


def test_wilcoxon_with_ties_and_a_zero_matches_r() -> None:
    # R: wilcox.test(extra ~ group, data = sleep, paired = TRUE) -> V = 0, p-value = 0.009091
    # (warnings: cannot compute exact p-value with ties / with zeroes; the zero pair is dropped).
    r = wilcoxon(SLEEP_1, SLEEP_2)
    assert r is not None
    assert r["V"] == 0 and r["n_nonzero"] == 9
    assert r["p"] == pytest.approx(0.009091, abs=1e-6)
    # By hand: ranks of |d| with one tie at 1.3 (4.5, 4.5); mean 9*10/4 = 22.5,
    # var = 9*10*19/24 - (2^3 - 2)/48 = 71.125; Z = (0 - 22.5)/sqrt(71.125) = -2.6679 (no continuity).
    assert r["z"] == pytest.approx(-2.6679, abs=1e-4)
    assert r["r"] == pytest.approx(-2.6679 / 3.0, abs=1e-4), "r = Z / sqrt(n)"


def test_wilcoxon_all_zero_differences_is_none() -> None:
    assert wilcoxon(SLEEP_1, SLEEP_1.copy()) is None


def test_anova_two_levels_is_t_squared() -> None:
    # For two levels F(1, n-1) = t^2 and partial eta^2 = F / (F + df_error) (textbook identities).
    a = rm_anova({"CC": SLEEP_1, "EC": SLEEP_2})
    assert (a["df1"], a["df2"]) == (1, 9)
    assert a["F"] == pytest.approx(4.0621277**2, rel=1e-6)
    assert a["partial_eta_sq"] == pytest.approx(16.500881 / (16.500881 + 9), rel=1e-6)
    assert a["p"] == pytest.approx(0.002833, abs=1e-6)
    assert a["sphericity"] == SPHERICITY_TWO_LEVELS


def test_anova_three_levels_matches_statsmodels_and_reports_sphericity() -> None:
    import pandas as pd
    from statsmodels.stats.anova import AnovaRM

    rng = np.random.default_rng(7)
    levels = {"A": rng.normal(0, 1, 12), "B": rng.normal(0.8, 1.5, 12), "C": rng.normal(0.2, 0.5, 12)}
    ours = rm_anova(levels)
    df = pd.DataFrame([{"s": i, "c": k, "v": v[i]} for k, v in levels.items() for i in range(12)])
    ref = AnovaRM(df, "v", "s", within=["c"]).fit().anova_table.iloc[0]
    assert ours["F"] == pytest.approx(ref["F Value"], rel=1e-9)
    assert (ours["df1"], ours["df2"]) == (int(ref["Num DF"]), int(ref["Den DF"]))
    assert ours["p"] == pytest.approx(ref["Pr > F"], rel=1e-6)
    assert 0.5 <= ours["gg_epsilon"] <= 1.0, "GG epsilon lies between 1/(k-1) and 1"
    assert 0 <= ours["mauchly_p"] <= 1 and isinstance(ours["sphericity_met"], bool)
    from scipy.stats import f

    eps = ours["gg_epsilon"]
    assert ours["p_gg"] == pytest.approx(f.sf(ours["F"], eps * 2, eps * 22), rel=1e-6), "GG scales both dfs"


# Reference values: R 4.2.2 with the effectsize package 0.8.3 (Ben-Shachar, Lüdecke & Makowski 2020,
# JOSS 5(56), 2815), `cohens_d(x, y, paired = TRUE)`, whose CI inverts the noncentral t
# distribution. Reproduced offline with Debian's r-cran-effectsize (`Rscript -e ...`, the calls are
# in the comments). The sleep example is effectsize's own documented one (?cohens_d: "Pair(extra[group
# == 1], extra[group == 2]) ~ 1, data = sleep" -> d = -1.28, 95% CI [-2.12, -0.41]).
DZ_REFERENCE = [
    # (x, y, level, d, ci_low, ci_high)
    (SLEEP_1, SLEEP_2, 0.95, -1.2845575626, -2.1180165952, -0.4146276621),  # cohens_d(x, y, paired = TRUE)
    (MICE_BEFORE, MICE_AFTER, 0.95, -6.603826611, -9.657852290, -3.545122276),
    (HW_X, HW_Y, 0.95, 1.0117918052, 0.1771477399, 1.8071690610),
    (HW_X, HW_Y, 0.90, 1.0117918052, 0.3035651863, 1.6716969949),  # ..., ci = 0.9
    # n = 4: cohens_d(c(4, 5, 5, 7), c(10, 12, 9, 14), paired = TRUE); t.test p = 0.0034
    (np.array([4.0, 5, 5, 7]), np.array([10.0, 12, 9, 14]), 0.95,
     -4.2426406871, -7.6104125224, -0.9447423674),
]


@pytest.mark.parametrize(("x", "y", "level", "d", "low", "high"), DZ_REFERENCE)
def test_cohens_dz_ci_matches_r_effectsize(
    x: np.ndarray, y: np.ndarray, level: float, d: float, low: float, high: float
) -> None:
    """Issue 19.8: the d_z interval must come from the noncentral t, not the normal approximation that
    put 0 inside the interval of a test with p < .01 (d -3.44 [-7.63, 0.74], p .006)."""
    from app.study.analysis import dz_interval

    got_d, ci = cohens_dz(x, y)
    assert got_d == pytest.approx(d, abs=1e-8)
    lo, hi = ci if level == 0.95 else dz_interval(got_d, x.size, level)
    assert (lo, hi) == pytest.approx((low, high), abs=1e-6)


def test_dz_interval_excludes_zero_exactly_when_the_t_test_is_significant() -> None:
    rng = np.random.default_rng(11)
    for n in (4, 5, 8, 20):
        for _ in range(15):
            x, y = rng.normal(0, 1, n), rng.normal(0.8, 1, n)
            d, ci = cohens_dz(x, y)
            p = paired_t(x, y)["p"]
            assert d is not None and ci is not None and p is not None
            assert (ci[0] > 0 or ci[1] < 0) == (p < 0.05), (n, d, ci, p)


def test_holm_and_bonferroni_match_r_p_adjust() -> None:
    from app.study.analysis import adjust_p

    p = [0.01, 0.04, 0.03, 0.005, 0.2, 0.5]
    # R: p.adjust(p, "holm"); p.adjust(p, "bonferroni")
    assert adjust_p(p, "holm") == pytest.approx([0.05, 0.12, 0.12, 0.03, 0.40, 0.50])
    assert adjust_p(p, "bonferroni") == pytest.approx([0.06, 0.24, 0.18, 0.03, 1.00, 1.00])
    assert adjust_p(p, "none") == p


@pytest.mark.parametrize(
    ("d", "label"),
    [
        (0.0, "negligible"),
        (0.005, "negligible"),
        (0.19, "negligible"),
        (0.2, "very small"),
        (-0.49, "very small"),
        (0.5, "small"),
        (0.8, "medium"),
        (1.19, "medium"),
        (1.2, "large"),
        (-1.99, "large"),
        (2.0, "very large"),
        (5.0, "very large"),
        (None, None),
        (float("nan"), None),
    ],
)
def test_effect_labels_of_the_paper(d: float | None, label: str | None) -> None:
    assert effect_label(d) == label


def test_normal_differences_choose_the_t_test() -> None:
    # R (STHDA): t.test(before, after, paired = TRUE) -> t = -20.883, df = 9, p-value = 6.2e-09
    r = paired_test(cc=MICE_AFTER, ec=MICE_BEFORE)  # EC - CC = before - after
    assert r["normal"] is True and r["test"] == "paired_t"
    assert r["statistic"] == pytest.approx(-20.883, abs=1e-3)
    assert r["p"] == pytest.approx(6.2e-9, rel=1e-2)
    assert r["mean_cc"] == pytest.approx(MICE_AFTER.mean()) and r["sd_ec"] == pytest.approx(
        MICE_BEFORE.std(ddof=1)
    )
    assert r["anova"]["F"] == pytest.approx(20.883**2, rel=1e-4)


def test_non_normal_differences_choose_wilcoxon() -> None:
    r = paired_test(cc=SLEEP_2, ec=SLEEP_1)
    assert r["normal"] is False and r["test"] == "wilcoxon"
    assert r["statistic"] == 0 and r["p"] == pytest.approx(0.009091, abs=1e-6)
    assert r["effect_label"] == "large" and r["cohens_d"] == pytest.approx(-1.284558, abs=1e-6)


@pytest.mark.parametrize("n", [0, 1, 2])
def test_not_enough_data(n: int) -> None:
    r = paired_test(SLEEP_1[:n], SLEEP_2[:n])
    assert r["n"] == n and r["test"] is None and r["p"] is None
    assert "not enough data" in r["note"]


def test_identical_conditions_give_no_test() -> None:
    r = paired_test(SLEEP_1, SLEEP_1.copy())
    assert r["test"] is None and "zero" in r["note"]


def test_constant_nonzero_differences_fall_back_to_wilcoxon() -> None:
    cc = np.arange(10.0)
    r = paired_test(cc, cc + 2.0)
    assert r["test"] == "wilcoxon" and r["p"] is not None and r["cohens_d"] is None


def test_mismatched_lengths_rejected() -> None:
    with pytest.raises(ValueError, match="equal length"):
        paired_test([1.0, 2.0, 3.0], [1.0, 2.0])


# --- analyse() over study records --------------------------------------------------------------

T0 = datetime(2026, 3, 2, 16, 0, tzinfo=UTC)


def _ssq(total: float) -> dict[str, float]:
    return {"nausea": total / 2, "oculomotor": total / 3, "disorientation": total / 4, "total": total}


def build_study(n_full: int, one_condition: int = 0, seed: int = 3) -> StudyData:
    """n_full participants with both sessions and all questionnaires, plus some with one session."""
    rng = np.random.default_rng(seed)
    participants, sessions, responses = [], [], []
    sid = rid = 0
    for i in range(n_full + one_condition):
        code = f"P{i + 1:02d}"
        first = "CC" if i % 2 == 0 else "EC"
        participants.append(ParticipantRecord(i + 1, code, first))
        conditions = (first, "EC" if first == "CC" else "CC")[: 1 if i >= n_full else 2]
        for k, cond in enumerate(conditions):
            sid += 1
            sessions.append(SessionRecord(sid, i + 1, cond, k + 1, "stopped", T0 + timedelta(days=2 * k)))
            base = 30.0 if cond == "CC" else 15.0
            sheets: list[tuple[str, str | None, dict[str, Any]]] = [
                ("ssq", "pre", _ssq(float(rng.integers(0, 10)) * 3.74)),
                ("ssq", "post", _ssq(base + float(rng.normal(0, 8)))),
                (
                    "ipq",
                    "post",
                    {"G1": 3.0 + (cond == "EC"), "SP": float(rng.uniform(2, 5)), "INV": 3.0, "REAL": 2.5},
                ),
                (
                    "nasa_tlx",
                    "post",
                    {
                        "raw_tlx": 40 + float(rng.normal(0, 5)),
                        **{
                            s: 50.0
                            for s in (
                                "mental",
                                "physical",
                                "temporal",
                                "performance",
                                "effort",
                                "frustration",
                            )
                        },
                    },
                ),
            ]
            if k == 0:
                sheets.append(("mssq", "pre", {"child": float(i), "adult": 2.0 * i, "total": 3.0 * i}))
            for instrument, phase, scores in sheets:
                rid += 1
                responses.append(ResponseRecord(rid, sid, instrument, phase, {}, scores))
    return StudyData(tuple(participants), tuple(sessions), tuple(responses))


def test_analyse_shape_and_exclusions() -> None:
    data = build_study(n_full=8, one_condition=2)
    a = analyse(data)
    assert a["participants"] == 10
    assert a["excluded"] == ["P09", "P10"], "participants with one condition only are listed"
    assert a["correction"] == "holm" and a["correction_text"].startswith("p adjusted for")
    tested = [m for m in a["measures"].values() if m["p"] is not None]
    assert a["family_size"] == len(tested) and all(m["p_adjusted"] >= m["p"] for m in tested)
    assert "tlx_weighted" in a["measures"], "the weighted TLX is analysed (issue 19.8)"
    assert set(a["measures"]) == set(MEASURES)
    for name, m in a["measures"].items():
        for key in (
            "n",
            "test",
            "statistic",
            "p",
            "cohens_d",
            "effect_label",
            "normal",
            "mean_cc",
            "sd_cc",
            "mean_ec",
            "sd_ec",
        ):
            assert key in m, f"{name} lacks {key}"
    ssq = a["measures"]["ssq_total_post"]
    assert ssq["n"] == 8 and ssq["test"] in ("paired_t", "wilcoxon") and "P09" not in ssq["participants"]
    assert ssq["mean_cc"] > ssq["mean_ec"], "the simulated EC sessions have lower SSQ"
    assert a["measures"]["ipq_G1"]["test"] == "wilcoxon", "every difference is exactly 1: not normal"
    assert a["measures"]["tlx_mental"]["test"] is None, "no differences at all"
    assert a["mssq"]["n"] == 10 and a["mssq"]["total"]["mean"] == pytest.approx(3.0 * 4.5)


def test_analyse_ssq_delta_is_post_minus_pre() -> None:
    data = build_study(n_full=4)
    a = analyse(data)
    s1 = [r for r in data.responses if r.session_id == 1]
    post = next(r for r in s1 if r.instrument == "ssq" and r.phase == "post").scores["total"]
    pre = next(r for r in s1 if r.instrument == "ssq" and r.phase == "pre").scores["total"]
    # P01 did CC in session 1.
    from app.study.analysis import condition_values

    assert condition_values(data, "ssq_total_delta")["P01"]["CC"] == pytest.approx(post - pre)
    assert a["measures"]["ssq_total_delta"]["n"] == 4


def test_analyse_too_few_participants_does_not_crash() -> None:
    a = analyse(build_study(n_full=2, one_condition=1))
    m = a["measures"]["ipq_SP"]
    assert m["n"] == 2 and m["test"] is None and "not enough data" in m["note"]
    assert a["excluded"] == ["P03"]
    empty = analyse(StudyData())
    assert empty["participants"] == 0 and empty["measures"]["tlx_raw"]["n"] == 0


def test_small_n_says_shapiro_wilk_cannot_judge_normality() -> None:
    r = paired_test(SLEEP_1[:4], SLEEP_2[:4])
    assert r["normality_underpowered"] is True and "too few pairs to judge normality" in r["normality_note"]
    assert "normality_note" not in paired_test(SLEEP_1, SLEEP_2), "n = 10 is enough"


def test_exclusions_and_corrections_are_honoured_named_and_listed() -> None:
    from dataclasses import replace

    data = build_study(n_full=6)
    p1 = data.participants[0]
    s_p2 = [s for s in data.sessions if s.participant_id == 2]
    post = next(r for r in data.responses if r.session_id == s_p2[0].id and r.instrument == "ssq"
                and r.phase == "post")  # fmt: skip
    fixed = replace(post, id=999, scores={**post.scores, "total": 123.0}, corrects=post.id)
    responses = (*(replace(r, superseded_by=999) if r is post else r for r in data.responses), fixed)
    data = StudyData(
        (replace(p1, excluded_reason="withdrew"), *data.participants[1:]), data.sessions, responses
    )
    a = analyse(data)
    m = a["measures"]["ssq_total_post"]
    assert m["n"] == 5 and "P01" not in m["participants"], "an excluded participant is left out"
    assert {"kind": "participant", "code": "P01", "id": 1, "reason": "withdrew"} in a["exclusions"]
    cond = s_p2[0].condition
    assert m["entries"]["P02"][cond] == [999], "the analysis names the entry it used: the correction"
    from app.study.analysis import condition_values

    assert condition_values(data.analysed(), "ssq_total_post")["P02"][cond] == 123.0


def test_timeline_colours_are_the_dashboards() -> None:
    """Issue 19.8: the timeline's action colours are the Command panel's."""
    import re
    from pathlib import Path

    from app.study.figures import ACTION_COLOURS

    css = (Path(__file__).resolve().parents[3] / "frontend" / "css" / "dashboard.css").read_text()
    for action, colour in ACTION_COLOURS.items():
        m = re.search(rf"--{action}:\s*(#[0-9a-fA-F]{{6}})", css)
        assert m is not None and m.group(1).lower() == colour.lower(), (action, colour)
