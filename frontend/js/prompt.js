// The participant's instruction while a take's protocol runs: the step's text in large type, a
// countdown of the seconds left in it, and what comes next. Polls GET /api/v1/takes/current.

import { get } from "./api.js";

const root = document.getElementById("prompt");
const text = document.getElementById("prompt-text");
const step = document.getElementById("prompt-step");
const countdown = document.getElementById("prompt-countdown");
const bar = document.getElementById("prompt-bar");
const next = document.getElementById("prompt-next");
let stepLength = {};

function show(cur) {
  const p = cur && cur.recording ? cur.prompt : null;
  if (!p) {
    root.dataset.state = "waiting";
    delete root.dataset.label;
    text.textContent = cur && cur.recording ? "Recording" : "Waiting for the experimenter…";
    step.textContent = "";
    countdown.textContent = "";
    next.textContent = "";
    return;
  }
  root.dataset.state = "prompt";
  root.dataset.label = p.label;
  const key = `${cur.take_id}:${p.index}`;
  stepLength[key] = Math.max(stepLength[key] || 0, p.remaining_s);
  text.textContent = p.text;
  step.textContent = `step ${p.index + 1} of ${p.steps}`;
  countdown.textContent = String(Math.ceil(p.remaining_s));
  bar.style.width = `${100 * (1 - p.remaining_s / stepLength[key])}%`;
  next.textContent = p.next ? `next: ${p.next}` : "last step";
}

async function poll() {
  try {
    show(await get("/takes/current"));
  } catch (err) {
    root.dataset.state = "waiting";
    text.textContent = `No connection (${err.message})`;
  }
}

poll();
setInterval(poll, 250);
