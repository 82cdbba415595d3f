// The navigator's current command, its probabilities, yaw and speed, and a short history strip.

import { el } from "../api.js";
import { onStatus } from "../live.js";

const HISTORY = 120; // about twelve seconds at ten updates a second

export function mountAction() {
  const label = document.getElementById("action-label");
  const probs = document.getElementById("action-probs");
  const history = document.getElementById("action-history");
  onStatus((s) => {
    const a = s.action;
    label.textContent = a ? a.label : "—";
    label.dataset.label = a ? a.label : "";
    document.getElementById("action-yaw").textContent = a && a.yaw_deg != null ? a.yaw_deg.toFixed(0) : "–";
    document.getElementById("action-speed").textContent = a && a.speed_mps != null ? a.speed_mps.toFixed(2) : "–";
    probs.replaceChildren(
      ...Object.entries(a ? a.probs : {}).map(([name, p]) =>
        el(
          "div",
          { class: "prob" },
          el("span", {}, name),
          el("span", { class: "bar" }, el("span", { class: `fill ${name}`, style: `width:${(100 * p).toFixed(0)}%` })),
          el("span", {}, p.toFixed(2)),
        ),
      ),
    );
    history.append(el("span", { class: `tick ${a ? a.label : "none"}`, title: a ? a.label : "no navigator" }));
    while (history.childElementCount > HISTORY) history.firstElementChild.remove();
  });
}
