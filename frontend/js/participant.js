// The participant page: the session's questionnaire steps one at a time (the instrument's own
// wording), a progress indicator, the runs' waiting screens, and a "thank you" end screen.
// It talks only to /api/v1/participant/*, with the credential from its link (#t=...), never with the
// operator token; it never shows scores.
// A lost connection (the tablet's Wi-Fi, a server restart) loses no answer: the sheet stays as it is,
// a notice says the page keeps trying, and it goes on by itself once the server answers again; the
// answers given so far are also kept in the tab's storage, so a reload brings them back. Only a
// credential the server refuses (401: a newer link replaced it) ends the page.

import { ApiError, el } from "./api.js";
import { collectAnswers, markItems, readDraft, renderSheet, restoreAnswers, writeDraft } from "./forms.js";

const fromLink = new URLSearchParams(location.hash.slice(1)).get("t");
if (fromLink) {
  sessionStorage.setItem("cavewalk-participant", fromLink);
  history.replaceState(null, "", location.pathname); // the credential leaves the address bar
}
const credential = sessionStorage.getItem("cavewalk-participant");

async function call(method, path, body) {
  const headers = { "X-Participant-Token": credential || "" };
  if (body !== undefined) headers["Content-Type"] = "application/json";
  const res = await fetch(`/api/v1/participant${path}`, { method, headers, body: body === undefined ? undefined : JSON.stringify(body) });
  const text = await res.text();
  let data = null;
  try {
    data = text ? JSON.parse(text) : null;
  } catch {
    data = null; // not ours (a proxy's error page): the status says what happened
  }
  if (!res.ok) throw new ApiError(res.status, data && typeof data.detail === "string" ? data.detail : res.statusText, data);
  return data;
}

const $ = (id) => document.getElementById(id);
const DRAFT = "cavewalk-participant-draft";
const RETRY_MS = 2000;
let defs = null;
let shown = null; // the step on screen: {key, instrument, phase}
let form = null;
let timer = null;

function progress(view) {
  const qs = view.steps.filter((s) => s.kind === "questionnaire");
  const done = qs.filter((s) => s.state === "done").length;
  const current = qs.findIndex((s) => s.key === view.current);
  $("p-progress-bar").style.width = `${(100 * done) / Math.max(1, qs.length)}%`;
  $("p-progress-text").textContent = view.complete
    ? "All done"
    : current >= 0
      ? `Questionnaire ${current + 1} of ${qs.length}`
      : `${done} of ${qs.length} questionnaires done`;
}

function clock(seconds) {
  const s = Math.max(0, Math.round(seconds));
  return `${Math.floor(s / 60)}:${String(s % 60).padStart(2, "0")}`;
}

function showEnd() {
  shown = null;
  $("p-title").textContent = "";
  $("p-instructions").textContent = "";
  $("p-sheet").replaceChildren();
  $("p-submit").hidden = true;
  $("p-problems").hidden = true;
  const wait = $("p-wait");
  wait.hidden = false;
  wait.replaceChildren(
    el(
      "div",
      { class: "p-end", id: "p-end" },
      el("h1", {}, "Thank you!"),
      el("p", {}, "You have answered everything. Please hand the tablet back to the experimenter."),
    ),
  );
}

function showWait(step, view) {
  shown = null;
  $("p-sheet").replaceChildren();
  $("p-title").textContent = "";
  $("p-instructions").textContent = "";
  $("p-submit").hidden = true;
  $("p-problems").hidden = true;
  const wait = $("p-wait");
  wait.hidden = false;
  if (step.state === "running") {
    wait.replaceChildren(
      el("p", {}, "The session is running. The next questions come when it is over."),
      step.remaining_s != null ? el("div", { class: "p-big", id: "p-countdown" }, clock(step.remaining_s)) : "",
    );
  } else {
    wait.replaceChildren(el("p", { id: "p-ready" }, "Thank you. The experimenter will start the session now."));
  }
  progress(view);
}

// The answers of the sheet on screen, kept in the tab's storage (this session's, this step's).
function saveDraft() {
  if (shown && form) writeDraft(DRAFT, form, defs[shown.instrument], { credential, key: shown.key });
}

function draftFor(step) {
  const draft = readDraft(DRAFT);
  return draft && draft.credential === credential && draft.key === step.key ? draft : null;
}

function connection(lost) {
  $("p-offline").hidden = !lost;
}

function showStep(step, view) {
  $("p-wait").hidden = true;
  progress(view);
  if (shown && shown.key === step.key) return; // keep what the participant is filling in
  const def = defs[step.instrument];
  shown = step;
  $("p-title").textContent = def.title;
  $("p-instructions").textContent = def.instructions;
  $("p-problems").hidden = true;
  form = renderSheet(def);
  const draft = draftFor(step);
  if (draft) restoreAnswers(form, def, draft);
  form.addEventListener("input", saveDraft);
  form.addEventListener("change", saveDraft);
  $("p-sheet").replaceChildren(form);
  $("p-submit").hidden = false;
  window.scrollTo({ top: 0 });
}

function render(view) {
  if (view.complete) {
    progress(view);
    showEnd();
    return;
  }
  const step = view.steps.find((s) => s.key === view.current);
  if (step.kind === "run") showWait(step, view);
  else showStep(step, view);
}

// A refusal of the credential ends the page; anything else (no answer, a server error) may pass.
const final = (err) => err instanceof ApiError && (err.status === 401 || err.status === 403);

async function refresh() {
  try {
    const view = await call("GET", "/session");
    connection(false);
    render(view);
  } catch (err) {
    if (final(err)) fail(err);
    else connection(true); // the sheet stays as it is; the next poll tries again
  }
}

function fail(err) {
  clearInterval(timer);
  $("p-progress-text").textContent = "";
  $("p-sheet").replaceChildren();
  $("p-submit").hidden = true;
  $("p-wait").hidden = false;
  $("p-wait").replaceChildren(el("p", { id: "p-denied" }, err.status === 401 ? err.message : `Something went wrong: ${err.message}. Please tell the experimenter.`));
}

async function submit() {
  const def = defs[shown.instrument];
  const { answers, pairwise } = collectAnswers(form, def);
  const body = { instrument: shown.instrument, phase: shown.phase, answers };
  if (pairwise) body.pairwise = pairwise;
  const button = $("p-submit");
  button.disabled = true;
  try {
    const view = await call("POST", "/questionnaires", body);
    sessionStorage.removeItem(DRAFT);
    shown = null;
    connection(false);
    render(view);
  } catch (err) {
    const items = err.body && Array.isArray(err.body.items) ? err.body.items : [];
    const box = $("p-problems");
    box.hidden = false;
    if (!(err instanceof ApiError) || err.status >= 500) {
      connection(true);
      box.replaceChildren(el("b", {}, "Your answers could not be sent: the connection to the experimenter's computer is lost. They are kept here: please press Next again in a moment."));
    } else if (err.status === 409) {
      // A Next whose answer was stored but whose reply was lost (the tablet's Wi-Fi) is refused
      // when pressed again: the step it answered is no longer due. Show what is due now instead.
      const before = shown && shown.key;
      await refresh();
      if (shown && shown.key === before) box.replaceChildren(el("b", {}, err.message));
      else box.hidden = true;
    } else if (err.status === 422 && items.length) {
      markItems(form, items, { scroll: false });
      const names = items.map((k) => {
        const row = form.querySelector(`.q-row[data-key="${k}"] .q-text`);
        return row ? row.textContent.trim() : k;
      });
      box.replaceChildren(
        el("b", {}, items.length === 1 ? "Please answer this question:" : `Please answer these ${items.length} questions:`),
        el("ul", {}, ...names.map((n) => el("li", {}, n))),
      );
    } else {
      box.replaceChildren(el("b", {}, err.message));
    }
    if (!box.hidden) box.scrollIntoView({ block: "start" });
  } finally {
    button.disabled = false;
  }
}

async function main() {
  if (!credential) {
    fail(new ApiError(401, "This page opens from the experimenter's link or QR code."));
    return;
  }
  for (;;) {
    try {
      defs = await call("GET", "/instruments");
      break;
    } catch (err) {
      if (final(err)) {
        fail(err);
        return;
      }
      connection(true); // the page opened while the server is out of reach: it keeps trying
      await new Promise((resolve) => setTimeout(resolve, RETRY_MS));
    }
  }
  $("p-submit").addEventListener("click", submit);
  await refresh();
  timer = setInterval(refresh, RETRY_MS);
}

main();
