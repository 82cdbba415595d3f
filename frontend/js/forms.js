// The questionnaire sheets, shared by the operator's form and the participant page: one item per
// row, big touch targets, the instrument's own wording and anchors (GET .../instruments).
// A sheet starts empty every time it is drawn; a slider nobody touched is unanswered; the NASA-TLX
// pairwise comparisons come in a random order (pairs and sides) and count only all 15 together.
// DOM contract (tests rely on it): one radio group per item named by the item key, or an
// input[type=range][name=key] with data-touched, .q-row[data-key] rows, .q-bad on rows with a problem.

import { el } from "./api.js";

export const INSTRUMENT_LABELS = { ssq: "SSQ", mssq: "MSSQ-short", ipq: "IPQ", nasa_tlx: "NASA-TLX" };

const SCALE_NAMES = {
  mental: "Mental Demand",
  physical: "Physical Demand",
  temporal: "Temporal Demand",
  performance: "Performance",
  effort: "Effort",
  frustration: "Frustration",
};

export function formatScore(value) {
  // At most two decimals, no trailing zeros: 37.4, 41.14, 18.
  return Number(Number(value).toFixed(2)).toString();
}

function shuffled(list, random = Math.random) {
  const out = [...list];
  for (let i = out.length - 1; i > 0; i -= 1) {
    const j = Math.floor(random() * (i + 1));
    [out[i], out[j]] = [out[j], out[i]];
  }
  return out;
}

function optionLabel(item, value, index, uid) {
  const perValue = item.anchors.length === item.max - item.min + 1;
  return el(
    "label",
    { class: "q-option" },
    el("input", { type: "radio", name: item.key, value: String(value), "data-form": uid }),
    el("span", { class: "q-option-face" }, el("b", {}, String(value)), perValue ? el("small", {}, item.anchors[index]) : ""),
  );
}

function choiceRow(item, number, uid) {
  const options = [];
  for (let v = item.min, i = 0; v <= item.max; v += 1, i += 1) options.push(optionLabel(item, v, i, uid));
  for (const extra of item.allow) {
    options.push(
      el(
        "label",
        { class: "q-option q-option-extra" },
        el("input", { type: "radio", name: item.key, value: extra, "data-form": uid }),
        el("span", { class: "q-option-face" }, el("small", {}, extra.replaceAll("_", " "))),
      ),
    );
  }
  const perValue = item.anchors.length === item.max - item.min + 1;
  return el(
    "div",
    { class: "q-row", dataset: { key: item.key } },
    el("div", { class: "q-text" }, el("span", { class: "q-num" }, `${number}.`), " ", item.text),
    el(
      "div",
      { class: "q-scale" },
      perValue ? "" : el("span", { class: "q-anchor" }, item.anchors[0]),
      el("div", { class: "q-options", role: "radiogroup", "aria-label": item.text }, ...options),
      perValue ? "" : el("span", { class: "q-anchor" }, item.anchors[item.anchors.length - 1]),
    ),
  );
}

function sliderRow(item, number) {
  // NASA-TLX: 0-100 in steps of 5 (the paper form's 21 marks); unanswered until moved.
  const out = el("output", { class: "q-value" }, "not set");
  const input = el("input", {
    type: "range",
    name: item.key,
    min: String(item.min),
    max: String(item.max),
    step: "5",
    value: String((item.min + item.max) / 2),
    "aria-label": item.text,
    "data-touched": "false",
  });
  const touch = () => {
    input.dataset.touched = "true";
    out.textContent = input.value;
  };
  input.addEventListener("input", touch);
  input.addEventListener("change", touch);
  return el(
    "div",
    { class: "q-row", dataset: { key: item.key } },
    el("div", { class: "q-text" }, el("span", { class: "q-num" }, `${number}.`), " ", item.text),
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

function pairRow(pair, number, uid) {
  const options = shuffled(pair.options);
  return el(
    "div",
    { class: "q-row q-pair", dataset: { key: pair.key } },
    el("div", { class: "q-text" }, el("span", { class: "q-num" }, `${number}.`), " Which contributed more to the workload?"),
    el(
      "div",
      { class: "q-options", role: "radiogroup", "aria-label": `pair ${number}` },
      ...options.map((o) =>
        el(
          "label",
          { class: "q-option q-option-wide" },
          el("input", { type: "radio", name: pair.key, value: o, "data-form": uid }),
          el("span", { class: "q-option-face" }, el("b", {}, SCALE_NAMES[o] || o)),
        ),
      ),
    ),
  );
}

let formCounter = 0;

// A fresh, empty sheet for one instrument.
export function renderSheet(def) {
  formCounter += 1;
  const uid = `f${formCounter}`;
  const rows = def.items.map((item, i) => (item.max - item.min > 10 ? sliderRow(item, i + 1) : choiceRow(item, i + 1, uid)));
  if (def.pairs.length) {
    rows.push(
      el(
        "h4",
        { class: "q-subtitle" },
        `Pairwise comparisons: answer all ${def.pairs.length} or none (the weighted score needs all ${def.pairs.length})`,
      ),
    );
    rows.push(...shuffled(def.pairs).map((p, i) => pairRow(p, i + 1, uid)));
  }
  const form = el("form", { class: "q-form", novalidate: "", dataset: { instrument: def.name } }, ...rows);
  form.addEventListener("change", (ev) => {
    const row = ev.target.closest(".q-row");
    if (row) row.classList.remove("q-bad");
  });
  return form;
}

// The answers given: radios checked, sliders moved. Nothing else is sent.
export function collectAnswers(form, def) {
  const answers = {};
  for (const item of def.items) {
    const checked = form.querySelector(`input[type="radio"][name="${item.key}"]:checked`);
    const slider = form.querySelector(`input[type="range"][name="${item.key}"][data-touched="true"]`);
    const input = checked || slider;
    if (!input) continue; // unanswered: the server names it
    answers[item.key] = item.allow.includes(input.value) ? input.value : Number(input.value);
  }
  let pairwise;
  const chosen = def.pairs.map((p) => [p.key, form.querySelector(`[name="${p.key}"]:checked`)]).filter(([, i]) => i);
  if (chosen.length) pairwise = Object.fromEntries(chosen.map(([k, i]) => [k, i.value]));
  return { answers, pairwise };
}

// A sheet's answers kept in ``store`` under ``key`` until it is stored, with ``extra`` fields saying
// whose they are; readDraft gives them back (null: none). The tab's own storage (sessionStorage, the
// default) survives a reload; the browser's (localStorage) also closing the tab.
export function writeDraft(key, form, def, extra, store = sessionStorage) {
  const { answers, pairwise } = collectAnswers(form, def);
  store.setItem(key, JSON.stringify({ ...extra, answers, pairwise }));
}

export function readDraft(key, store = sessionStorage) {
  try {
    return JSON.parse(store.getItem(key) || "null");
  } catch {
    return null;
  }
}

// Put answers back into a fresh sheet of the same instrument (a draft kept across a reload): radios
// checked, sliders set and marked as moved; values the sheet does not offer are left out.
export function restoreAnswers(form, def, { answers = {}, pairwise } = {}) {
  const check = (name, value) => {
    const radio = form.querySelector(`input[type="radio"][name="${CSS.escape(name)}"][value="${CSS.escape(String(value))}"]`);
    if (radio) radio.checked = true;
  };
  for (const item of def.items) {
    if (!(item.key in answers)) continue;
    const slider = form.querySelector(`input[type="range"][name="${CSS.escape(item.key)}"]`);
    if (slider) {
      slider.value = String(answers[item.key]);
      slider.dispatchEvent(new Event("input")); // marks it moved and shows its value
    } else {
      check(item.key, answers[item.key]);
    }
  }
  for (const [key, value] of Object.entries(pairwise || {})) check(key, value);
}

// Mark every row the server named (its 422 lists them in "items"); scroll to the first.
export function markItems(form, keys, { scroll = true } = {}) {
  form.querySelectorAll(".q-row.q-bad").forEach((r) => r.classList.remove("q-bad"));
  let first = null;
  for (const key of keys || []) {
    const row = form.querySelector(`.q-row[data-key="${key}"]`);
    if (row) {
      row.classList.add("q-bad");
      first = first || row;
    }
  }
  if (first && scroll) first.scrollIntoView({ block: "center", behavior: "smooth" });
  return first !== null;
}
