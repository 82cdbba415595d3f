// The study's analysis panel: the paper's figures, the table of tests per measure, exclusions,
// design warnings, downloads (CSV, JSON) and a per-session timeline of the recognised actions.

import { get, el, withToken } from "./api.js";

const FIGURES = [
  ["ssq", "SSQ"],
  ["ipq", "IPQ"],
  ["tlx", "NASA-TLX"],
];

function num(x, digits = 2) {
  return x === null || x === undefined ? "–" : Number(x).toFixed(digits);
}

function pText(p) {
  if (p === null || p === undefined) return "–";
  return p < 0.001 ? "< .001" : Number(p).toFixed(3);
}

function statText(m) {
  if (m.test === "paired_t") {
    const a = m.anova ? `; F(1, ${m.anova.df2}) = ${num(m.anova.F)}, ηp² = ${num(m.anova.partial_eta_sq, 3)}` : "";
    return `t(${m.df}) = ${num(m.statistic)}${a}`;
  }
  if (m.test === "wilcoxon") return `Z = ${num(m.z)}, W = ${num(m.statistic, 1)}, r = ${num(m.r)}`;
  return m.note || "–";
}

function normalText(m) {
  if (m.normal === null) return "–";
  const word = m.normal ? "yes" : "no";
  return m.normality_underpowered ? `${word} (n too small to judge)` : word;
}

function measureRow(name, m) {
  const ci = m.cohens_d_ci95 ? ` [${num(m.cohens_d_ci95[0])}, ${num(m.cohens_d_ci95[1])}]` : "";
  return el(
    "tr",
    { class: m.significant ? "significant" : "", dataset: { measure: name }, title: m.normality_note || "" },
    el("td", {}, name),
    el("td", {}, m.n),
    el("td", {}, `${num(m.mean_cc)} (${num(m.sd_cc)})`),
    el("td", {}, `${num(m.mean_ec)} (${num(m.sd_ec)})`),
    el("td", { class: "normal" }, normalText(m)),
    el("td", {}, m.test || "–"),
    el("td", {}, statText(m)),
    el("td", {}, pText(m.p)),
    el("td", { class: "p-adjusted" }, pText(m.p_adjusted)),
    el("td", {}, `${num(m.cohens_d)}${ci}`),
    el("td", {}, m.effect_label || "–"),
  );
}

export function mountAnalysis(element) {
  element.classList.add("analysis");
  const refreshButton = el("button", { type: "button", id: "analysis-refresh" }, "Refresh analysis");
  const links = el(
    "span",
    {},
    el("a", { href: withToken("/api/v1/export.csv"), download: "cavewalk-study.csv" }, "CSV (long format)"),
    " · ",
    el("a", { href: withToken("/api/v1/export/sessions.csv"), download: "cavewalk-sessions.csv" }, "sessions CSV"),
    " · ",
    el("a", { href: withToken("/api/v1/analysis.json"), download: "cavewalk-analysis.json" }, "analysis JSON"),
  );
  const correction = el(
    "select",
    { id: "analysis-correction", "aria-label": "multiple-comparison correction" },
    el("option", { value: "holm" }, "Holm"),
    el("option", { value: "bonferroni" }, "Bonferroni"),
    el("option", { value: "none" }, "no correction"),
  );
  const summary = el("p", { id: "analysis-summary" });
  const caption = el("p", { id: "analysis-caption", class: "a-caption" });
  const warnings = el("ul", { class: "a-warnings", id: "analysis-warnings" });
  const figures = el("div", { class: "a-figures", id: "analysis-figures" });
  const table = el(
    "table",
    { id: "analysis-table" },
    el(
      "thead",
      {},
      el(
        "tr",
        {},
        ...["measure", "n", "CC mean (SD)", "EC mean (SD)", "normal", "test", "statistic", "p", "p adj.", "d_z [95 % CI]", "effect"].map(
          (h) => el("th", {}, h),
        ),
      ),
    ),
    el("tbody"),
  );
  const sessionSelect = el("select", { id: "analysis-timeline-session", "aria-label": "session" });
  const timeline = el("div", { class: "a-timeline" });
  element.replaceChildren(
    el("div", { class: "a-actions" }, refreshButton, el("label", {}, "correction ", correction), links),
    summary,
    warnings,
    figures,
    caption,
    table,
    el("h3", {}, "Session timeline (actions over time) ", sessionSelect),
    timeline,
  );

  function showTimeline() {
    const id = sessionSelect.value;
    timeline.replaceChildren(
      id ? el("img", { alt: `actions over time in session ${id}`, src: withToken(`/api/v1/analysis/sessions/${id}/timeline.png?t=${Date.now()}`) }) : "",
    );
  }
  sessionSelect.addEventListener("change", showTimeline);

  async function refresh() {
    refreshButton.disabled = true;
    try {
      const [analysis, design, sessions] = await Promise.all([
        get(`/analysis?correction=${correction.value}`),
        get("/study/design"),
        get("/sessions"),
      ]);
      const left = analysis.excluded.length
        ? ` Left out of the paired tests: ${analysis.excluded.map((c) => `${c} (${analysis.excluded_reasons[c]})`).join(", ")}.`
        : "";
      const counts = design.first_condition_counts;
      summary.textContent =
        `${analysis.participants} participants registered, ${design.completed_participants} completed both conditions ` +
        `(CC first: ${counts.CC}, EC first: ${counts.EC})` +
        (design.incomplete.length ? `; incomplete: ${design.incomplete.join(", ")}` : "") +
        `. Next: ${design.next_order.join(" → ")}. Differences are EC − CC.${left}`;
      const incomplete = design.completeness.filter((c) => !c.complete).map((c) => c.code);
      warnings.replaceChildren(
        ...design.gap_warnings.map((w) => el("li", {}, w.message)),
        ...(incomplete.length ? [el("li", {}, `questionnaires missing: ${incomplete.join(", ")}`)] : []),
        ...analysis.exclusions.map((e) => el("li", { class: "a-excluded" }, `excluded ${e.kind} ${e.id} (${e.code}): ${e.reason}`)),
      );
      caption.textContent =
        `p: unadjusted; p adj.: ${analysis.correction_text}; bold = significant after the correction (α = ${analysis.alpha}). ` +
        "d_z: Cohen's d for paired data with its exact 95 % CI. \"n too small to judge\": Shapiro-Wilk has little power below 10 pairs.";
      const stamp = Date.now();
      figures.replaceChildren(
        ...FIGURES.map(([name, label]) =>
          el(
            "figure",
            {},
            el("img", { alt: `${label} by condition`, src: withToken(`/api/v1/analysis/figures/${name}.png?t=${stamp}`) }),
            el("figcaption", {}, el("a", { href: withToken(`/api/v1/analysis/figures/${name}.svg`), target: "_blank" }, `${label} (SVG)`)),
          ),
        ),
      );
      table.tBodies[0].replaceChildren(...Object.entries(analysis.measures).map(([name, m]) => measureRow(name, m)));
      const keep = sessionSelect.value;
      sessionSelect.replaceChildren(
        el("option", { value: "" }, "—"),
        ...sessions.map((s) => el("option", { value: s.id }, `${s.id}: ${s.participant_code} ${s.condition}`)),
      );
      sessionSelect.value = keep;
      showTimeline();
    } catch (err) {
      summary.textContent = `analysis unavailable: ${err.message}`;
    } finally {
      refreshButton.disabled = false;
    }
  }
  refreshButton.addEventListener("click", refresh);
  correction.addEventListener("change", refresh);
  refresh();
}
