// The step strip: why the command is what it is. Under the command history, the same time axis:
// each foot's contact (planted / swinging, coloured by what the step looks like), and the
// stepping-bout gate's verdict; below, the newest step's displacement in the body frame and the
// gate's reason in words. Data: the live status' action.steps (pipeline/recognition/steps.py and
// bout.py, see MODEL_CARD.md "Behaviour").

import { el } from "../api.js";
import { onStatus } from "../live.js";

const HISTORY = 120; // as the command history: about twelve seconds at ten updates a second

const REASON_TEXT = {
  planted: "both feet planted: no step, no movement",
  lifting: "a foot is lifting: waiting to see a step",
  stepping: "a step in progress",
  pause: "pause between steps: the bout holds while the next step is due",
  "rhythm-broke": "the next step did not come in time: the bout ended",
  jump: "both feet left the floor together: a jump, not a step",
  crouched: "crouched: no movement",
  pivot: "the body turned during the step: turning on the spot",
  "network-still": "the network does not call this step movement",
  "feet-unknown": "a foot is not seen",
  "not-upright": "the body is not upright (bent over, lying): no movement",
  kick: "the leg was raised far (a kick): no step, no movement",
  "step-back": "a foot slid far back low (going down into a kneel or a lunge): no step, no movement",
  rhythm: "steps in a steady rhythm the network does not recognise: moving on the steps alone",
  "start-head": "a step the legs-only start head is sure of; the full-body network is not yet",
};

function cm(v) {
  return v == null ? "–" : `${(100 * v).toFixed(0)}`;
}

function raised(foot) {
  return foot.raise_deg == null ? "" : `, leg raised ${foot.raise_deg.toFixed(0)}°`;
}

export function footTick(foot) {
  if (!foot || !foot.known) return el("span", { class: "tick unknown", title: "not seen" });
  if (foot.planted) return el("span", { class: "tick planted", title: "planted" });
  const cls = foot.jump ? "jump" : foot.kind;
  return el("span", {
    class: `tick swing ${cls}`,
    title: `swinging: ${foot.jump ? "jump" : foot.kind}, lateral ${cm(foot.lateral_m)} cm, ` +
      `sagittal ${cm(foot.sagittal_m)} cm, up ${cm(foot.vertical_m)} cm${raised(foot)}`,
  });
}

function row(name, id) {
  return el("div", { class: "strip-row" }, el("span", { class: "strip-name" }, name),
    el("div", { class: "history strip", id }));
}

function push(strip, tick) {
  strip.append(tick);
  while (strip.childElementCount > HISTORY) strip.firstElementChild.remove();
}

export function mountSteps(container) {
  const left = row("L foot", "steps-left");
  const right = row("R foot", "steps-right");
  const gate = row("gate", "steps-gate");
  const detail = el("div", { class: "strip-detail", id: "steps-detail" }, "no step evidence yet");
  container.replaceChildren(el("div", { class: "step-strip" }, left, right, gate, detail));
  const [lStrip, rStrip, gStrip] = [left, right, gate].map((r) => r.querySelector(".strip"));
  onStatus((s) => {
    const ev = s.action && s.action.steps;
    if (!ev) {
      for (const strip of [lStrip, rStrip, gStrip]) push(strip, el("span", { class: "tick none" }));
      detail.textContent = s.action ? "no step evidence in the status" : "no navigator";
      return;
    }
    push(lStrip, footTick(ev.feet[0]));
    push(rStrip, footTick(ev.feet[1]));
    const g = ev.gate;
    push(gStrip, el("span", {
      class: `tick gate ${g ? g.reason : "off"}`,
      title: g ? `${g.command}: ${REASON_TEXT[g.reason] || g.reason}` : "gate off",
    }));
    const k = ev.stepping === "left" ? 0 : ev.stepping === "right" ? 1 : -1;
    const f = k >= 0 ? ev.feet[k] : null;
    const step = f
      ? `newest step: ${ev.stepping} foot, ${f.kind}${f.jump ? " (jump)" : ""}; lateral ${cm(f.lateral_m)} cm, ` +
        `sagittal ${cm(f.sagittal_m)} cm, up ${cm(f.vertical_m)} cm${raised(f)}`
      : "no step yet";
    const why = g
      ? `gate: ${g.command} (${REASON_TEXT[g.reason] || g.reason}` +
        (g.deadline_s != null && ev.t != null ? `; next step due within ${Math.max(0, g.deadline_s - ev.t).toFixed(2)} s` : "") +
        ")" + (g.evidence ? `; evidence points ${g.evidence}` : "")
      : "gate off: the network's command alone";
    detail.textContent = `${step}. ${why}.${ev.crouched ? " Crouched." : ""}`;
  });
}
