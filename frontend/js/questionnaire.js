// Questionnaire forms a participant fills on a tablet: one item per row, big touch targets,
// the instrument's own wording and anchors (from GET /questionnaires/instruments), posted to
// POST /sessions/{id}/questionnaires, which scores them. DOM contract (tests rely on it):
// #q-instrument, #q-phase, one radio group (or slider) per item named by the item key,
// #q-submit, the scores in #q-scores ("total: 37.4"), the server's 422 message in #q-error.

import { get, post, el } from "./api.js";

let definitionsPromise = null;

function definitions() {
  if (!definitionsPromise) {
    definitionsPromise = get("/questionnaires/instruments").catch((err) => {
      definitionsPromise = null;
      throw err;
    });
  }
  return definitionsPromise;
}

const INSTRUMENT_LABELS = { ssq: "SSQ", mssq: "MSSQ-short", ipq: "IPQ", nasa_tlx: "NASA-TLX" };

export function formatScore(value) {
  // At most two decimals, no trailing zeros: 37.4, 41.14, 18.
  return Number(Number(value).toFixed(2)).toString();
}

function optionLabel(item, value, index) {
  const perValue = item.anchors.length === item.max - item.min + 1;
  return el(
    "label",
    { class: "q-option" },
    el("input", { type: "radio", name: item.key, value: String(value) }),
    el("span", { class: "q-option-face" }, el("b", {}, String(value)), perValue ? el("small", {}, item.anchors[index]) : ""),
  );
}

function choiceRow(item) {
  const options = [];
  for (let v = item.min, i = 0; v <= item.max; v += 1, i += 1) options.push(optionLabel(item, v, i));
  for (const extra of item.allow) {
    options.push(
      el(
        "label",
        { class: "q-option q-option-extra" },
        el("input", { type: "radio", name: item.key, value: extra }),
        el("span", { class: "q-option-face" }, el("small", {}, extra.replaceAll("_", " "))),
      ),
    );
  }
  const perValue = item.anchors.length === item.max - item.min + 1;
  return el(
    "div",
    { class: "q-row", dataset: { key: item.key } },
    el("div", { class: "q-text" }, item.text),
    el(
      "div",
      { class: "q-scale" },
      perValue ? "" : el("span", { class: "q-anchor" }, item.anchors[0]),
      el("div", { class: "q-options", role: "radiogroup", "aria-label": item.text }, ...options),
      perValue ? "" : el("span", { class: "q-anchor" }, item.anchors[item.anchors.length - 1]),
    ),
  );
}

function sliderRow(item) {
  // NASA-TLX: 0-100 in steps of 5 (the paper form's 21 marks).
  const out = el("output", { class: "q-value" }, "50");
  const input = el("input", {
    type: "range",
    name: item.key,
    min: String(item.min),
    max: String(item.max),
    step: "5",
    value: "50",
    "aria-label": item.text,
  });
  input.addEventListener("input", () => {
    out.textContent = input.value;
  });
  return el(
    "div",
    { class: "q-row", dataset: { key: item.key } },
    el("div", { class: "q-text" }, item.text),
    el(
      "div",
      { class: "q-scale q-slider" },
      el("span", { class: "q-anchor" }, item.anchors[0]),
      input,
      el("span", { class: "q-anchor" }, item.anchors[item.anchors.length - 1]),
      out,
    ),
  );
}

function pairRow(pair) {
  return el(
    "div",
    { class: "q-row q-pair", dataset: { key: pair.key } },
    el("div", { class: "q-text" }, "Which contributed more to the workload?"),
    el(
      "div",
      { class: "q-options", role: "radiogroup", "aria-label": pair.key },
      ...pair.options.map((o) =>
        el(
          "label",
          { class: "q-option q-option-wide" },
          el("input", { type: "radio", name: pair.key, value: o }),
          el("span", { class: "q-option-face" }, el("b", {}, o)),
        ),
      ),
    ),
  );
}

function collect(form, def) {
  const answers = {};
  for (const item of def.items) {
    const input = form.querySelector(`[name="${item.key}"]:checked`) || form.querySelector(`input[type="range"][name="${item.key}"]`);
    if (!input) continue; // left out: the server's 422 names the missing item
    answers[item.key] = item.allow.includes(input.value) ? input.value : Number(input.value);
  }
  let pairwise;
  const chosen = def.pairs.map((p) => [p.key, form.querySelector(`[name="${p.key}"]:checked`)]).filter(([, i]) => i);
  if (chosen.length) pairwise = Object.fromEntries(chosen.map(([k, i]) => [k, i.value]));
  return { answers, pairwise };
}

function highlight(form, def, message) {
  form.querySelectorAll(".q-row.q-bad").forEach((r) => r.classList.remove("q-bad"));
  const keys = [...def.items.map((i) => i.key), ...def.pairs.map((p) => p.key)];
  const bad = keys.find((k) => message.includes(`'${k}'`));
  if (!bad) return;
  const row = form.querySelector(`.q-row[data-key="${bad}"]`);
  if (row) {
    row.classList.add("q-bad");
    row.scrollIntoView({ block: "center", behavior: "smooth" });
  }
}

export async function mountQuestionnaire(element, { sessionId }) {
  element.classList.add("questionnaire");
  const instrument = el("select", { id: "q-instrument", "aria-label": "questionnaire" });
  const phase = el("select", { id: "q-phase", "aria-label": "phase" });
  const title = el("h3", { class: "q-title" });
  const instructions = el("p", { class: "q-instructions" });
  const form = el("form", { class: "q-form", novalidate: "" });
  const submit = el("button", { id: "q-submit", type: "button", class: "q-submit" }, "Submit");
  const error = el("div", { id: "q-error", class: "q-error", role: "alert" });
  const scores = el("div", { id: "q-scores", class: "q-scores", "aria-live": "polite" });
  const done = el("div", { id: "q-done", class: "q-done" });
  element.replaceChildren(
    el("div", { class: "q-head" }, el("label", {}, "Questionnaire ", instrument), el("label", {}, "Phase ", phase)),
    title,
    instructions,
    form,
    el("div", { class: "q-foot" }, submit, error, scores),
    done,
  );

  let defs;
  try {
    defs = await definitions();
  } catch (err) {
    error.textContent = `cannot load the questionnaires: ${err.message}`;
    return;
  }
  instrument.replaceChildren(...Object.keys(defs).map((k) => el("option", { value: k }, INSTRUMENT_LABELS[k] || k)));

  function render() {
    const def = defs[instrument.value];
    const keep = phase.value;
    phase.replaceChildren(...def.phases.map((p) => el("option", { value: p ?? "" }, p ?? "—")));
    if (def.phases.map((p) => p ?? "").includes(keep)) phase.value = keep;
    title.textContent = def.title;
    instructions.textContent = def.instructions;
    const rows = def.items.map((item) => (item.max - item.min > 10 ? sliderRow(item) : choiceRow(item)));
    if (def.pairs.length) {
      rows.push(el("h4", { class: "q-subtitle" }, "Pairwise comparisons (optional: for the weighted score, answer all 15)"));
      rows.push(...def.pairs.map(pairRow));
    }
    form.replaceChildren(...rows);
    error.textContent = "";
    scores.textContent = "";
  }

  async function refreshDone() {
    try {
      const list = await get(`/sessions/${sessionId}/questionnaires`);
      done.textContent = list.length
        ? `Submitted for this session: ${list.map((q) => `${INSTRUMENT_LABELS[q.instrument] || q.instrument}${q.phase ? ` (${q.phase})` : ""}`).join(", ")}`
        : "Nothing submitted for this session yet.";
    } catch {
      done.textContent = "";
    }
  }

  instrument.addEventListener("change", render);
  submit.addEventListener("click", async () => {
    const def = defs[instrument.value];
    const { answers, pairwise } = collect(form, def);
    const body = { instrument: instrument.value, phase: phase.value || null, answers };
    if (pairwise) body.pairwise = pairwise;
    submit.disabled = true;
    error.textContent = "";
    scores.textContent = "";
    try {
      const res = await post(`/sessions/${sessionId}/questionnaires`, body);
      scores.textContent = Object.entries(res.scores)
        .map(([k, v]) => `${k}: ${formatScore(v)}`)
        .join(", ");
      form.querySelectorAll(".q-row.q-bad").forEach((r) => r.classList.remove("q-bad"));
      await refreshDone();
    } catch (err) {
      error.textContent = err.message;
      highlight(form, def, err.message);
    } finally {
      submit.disabled = false;
    }
  });
  render();
  await refreshDone();
}
