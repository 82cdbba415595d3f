// The operator's questionnaire form for one session (the participant fills theirs on the tablet:
// participant.html). It is bound to the session it was opened for, which its header shows; it is
// drawn empty for every instrument and phase; the phase must be chosen where there is a choice.
// A duplicate (409) offers an explicit correction with a reason; a broken design rule (409) an
// override with a reason; a 422 marks every unanswered item at once. The sheet being typed in is
// kept in the browser's storage (localStorage) until it is stored, so a reload of the dashboard or
// a closed tab brings it back (this session's form only).
// DOM contract (tests rely on it): #q-session (the header), #q-instrument, #q-phase, the sheet of
// forms.js, #q-submit, the scores in #q-scores ("total: 37.4"), the server's message in #q-error,
// #q-correct-reason + #q-correct for a correction or an override.

import { get, post, el } from "./api.js";
import {
  INSTRUMENT_LABELS,
  collectAnswers,
  formatScore,
  markItems,
  readDraft,
  renderSheet,
  restoreAnswers,
  writeDraft,
} from "./forms.js";

let definitionsPromise = null;

export function definitions() {
  if (!definitionsPromise) {
    definitionsPromise = get("/questionnaires/instruments").catch((err) => {
      definitionsPromise = null;
      throw err;
    });
  }
  return definitionsPromise;
}

export { formatScore };

export async function mountQuestionnaire(element, { session, onSubmitted = () => {} }) {
  const sessionId = session.id;
  element.classList.add("questionnaire");
  element.dataset.sessionId = String(sessionId);
  const header = el(
    "div",
    { id: "q-session", class: "q-session", dataset: { sessionId } },
    `Entering for session ${sessionId} · ${session.participant_code} · ${session.condition}`,
  );
  const instrument = el("select", { id: "q-instrument", "aria-label": "questionnaire" });
  const phase = el("select", { id: "q-phase", "aria-label": "phase" });
  const title = el("h3", { class: "q-title" });
  const instructions = el("p", { class: "q-instructions" });
  const sheet = el("div", { class: "q-sheet" });
  const submit = el("button", { id: "q-submit", type: "button", class: "q-submit" }, "Submit");
  const error = el("div", { id: "q-error", class: "q-error", role: "alert" });
  const scores = el("div", { id: "q-scores", class: "q-scores", "aria-live": "polite" });
  const fix = el("div", { class: "q-fix", hidden: "" });
  const done = el("div", { id: "q-done", class: "q-done" });
  element.replaceChildren(
    header,
    el("div", { class: "q-head" }, el("label", {}, "Questionnaire ", instrument), el("label", {}, "Phase ", phase)),
    title,
    instructions,
    sheet,
    el("div", { class: "q-foot" }, submit, error, scores),
    fix,
    done,
  );

  let defs;
  try {
    defs = await definitions();
  } catch (err) {
    error.textContent = `cannot load the questionnaires: ${err.message}`;
    return;
  }
  instrument.replaceChildren(
    el("option", { value: "" }, "choose…"),
    ...Object.keys(defs).map((k) => el("option", { value: k }, INSTRUMENT_LABELS[k] || k)),
  );
  let form = null;
  // the operator's own computer: the draft survives a reload and a closed tab (localStorage), until
  // it is stored (the participant's tablet keeps its drafts only as long as its tab)
  const draftKey = `cavewalk-operator-draft:${sessionId}`;

  function saveDraft() {
    const def = defs[instrument.value];
    if (def && form) {
      writeDraft(draftKey, form, def, { instrument: instrument.value, phase: phase.value }, localStorage);
    }
  }

  function clearMessages() {
    error.textContent = "";
    scores.textContent = "";
    fix.hidden = true;
    fix.replaceChildren();
  }

  function drawPhases() {
    const def = defs[instrument.value];
    const phases = def ? def.phases.filter((p) => p) : [];
    phase.replaceChildren(
      ...(phases.length > 1 ? [el("option", { value: "" }, "choose…")] : []),
      ...phases.map((p) => el("option", { value: p }, p)),
    );
    phase.disabled = phases.length <= 1;
  }

  function draw() {
    // a fresh, empty sheet every time: nothing carries over from another instrument or phase
    clearMessages();
    const def = defs[instrument.value];
    if (!def) {
      title.textContent = "";
      instructions.textContent = "";
      sheet.replaceChildren();
      form = null;
      return;
    }
    title.textContent = `${def.title}${phase.value ? ` — ${phase.value}` : ""}`;
    instructions.textContent = def.instructions;
    form = renderSheet(def);
    form.addEventListener("input", saveDraft);
    form.addEventListener("change", saveDraft);
    sheet.replaceChildren(form);
  }

  function restoreDraft() {
    // the sheet this form was typing into before a reload or a closed tab (the last instrument drawn)
    const draft = readDraft(draftKey, localStorage);
    if (!draft || !defs[draft.instrument]) return;
    instrument.value = draft.instrument;
    drawPhases();
    if ([...phase.options].some((o) => o.value === draft.phase)) phase.value = draft.phase;
    draw();
    restoreAnswers(form, defs[draft.instrument], draft);
  }

  async function refreshDone() {
    try {
      const list = await get(`/sessions/${sessionId}/questionnaires`);
      const used = list.filter((q) => q.in_use);
      done.textContent = used.length
        ? `Submitted for session ${sessionId}: ${used.map((q) => `${INSTRUMENT_LABELS[q.instrument] || q.instrument}${q.phase ? ` ${q.phase}` : ""} (entry ${q.id})`).join(", ")}`
        : `Nothing submitted for session ${sessionId} yet.`;
    } catch {
      done.textContent = "";
    }
  }

  function offer(kind, label, extra) {
    // a correction (duplicate entry) or an override (a rule of the design), always with a reason
    const reason = el("input", { id: "q-correct-reason", placeholder: "reason (kept in the audit trail)", maxlength: "2000" });
    const go = el("button", { id: "q-correct", type: "button" }, label);
    go.addEventListener("click", () => {
      if (reason.value.trim().length < 3) {
        error.textContent = "give a reason (at least 3 characters)";
        return;
      }
      send({ ...extra(reason.value.trim()) });
    });
    fix.replaceChildren(el("span", {}, kind), reason, go);
    fix.hidden = false;
  }

  async function send(extra = {}) {
    const def = defs[instrument.value];
    if (!def || !form) {
      error.textContent = "choose a questionnaire";
      return;
    }
    if (!phase.value) {
      error.textContent = "choose the phase (pre or post)";
      phase.focus();
      return;
    }
    const { answers, pairwise } = collectAnswers(form, def);
    const body = { instrument: instrument.value, phase: phase.value, answers, ...extra };
    if (pairwise) body.pairwise = pairwise;
    submit.disabled = true;
    clearMessages();
    try {
      const res = await post(`/sessions/${sessionId}/questionnaires`, body);
      localStorage.removeItem(draftKey);
      scores.textContent = Object.entries(res.scores)
        .map(([k, v]) => `${k}: ${formatScore(v)}`)
        .join(", ");
      markItems(form, []);
      await refreshDone();
      onSubmitted(res);
    } catch (err) {
      error.textContent = err.message;
      const items = err.body && Array.isArray(err.body.items) ? err.body.items : [];
      if (err.status === 422) markItems(form, items);
      const entry = /"correction_of": (\d+)/.exec(err.message);
      if (err.status === 409 && entry) {
        offer(`Replace entry ${entry[1]} with this sheet:`, "Submit as a correction", (reason) => ({
          correction_of: Number(entry[1]),
          reason,
        }));
      } else if (err.status === 409 && err.message.includes("override_reason")) {
        offer("Record it anyway:", "Override and submit", (reason) => ({ override_reason: reason }));
      }
    } finally {
      submit.disabled = false;
    }
  }

  instrument.addEventListener("change", () => {
    drawPhases();
    draw();
    saveDraft();
  });
  phase.addEventListener("change", () => {
    draw();
    saveDraft();
  });
  submit.addEventListener("click", () => send());
  drawPhases();
  draw();
  restoreDraft();
  await refreshDone();
}
