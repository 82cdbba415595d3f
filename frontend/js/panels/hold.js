// The operator's hold: while it is on, every locomotion command to the walls says still, whatever
// the participant does (PUT /navigation/hold); the recogniser goes on, and the notice says what it
// says. The button and the key H toggle it (not while typing in a form); the live status shows the
// server's state, so every open dashboard agrees. A controller (CC) session holds by itself while it
// runs (held_by "session"): the notice says so, and the operator may still release it.

import { put, toast } from "../api.js";
import { onStatus } from "../live.js";

export function mountHold() {
  const button = document.getElementById("hold-toggle");
  const notice = document.getElementById("hold-notice");
  const recognised = document.getElementById("hold-recognised");
  const why = document.getElementById("hold-why");
  let held = false;
  let busy = false;

  function show(on) {
    held = on;
    button.setAttribute("aria-pressed", on ? "true" : "false");
    button.textContent = on ? "Release navigation" : "Hold navigation";
    notice.hidden = !on;
  }

  async function set(on) {
    if (busy) return;
    busy = true;
    try {
      show((await put("/navigation/hold", { held: on })).held);
    } catch (err) {
      toast(`hold not changed: ${err.message}`);
    } finally {
      busy = false;
    }
  }

  button.addEventListener("click", () => set(!held));
  document.getElementById("hold-release").addEventListener("click", () => set(false));
  document.addEventListener("keydown", (ev) => {
    const typing = ev.target.closest && ev.target.closest("input, textarea, select, [contenteditable]");
    if (ev.key.toLowerCase() !== "h" || ev.ctrlKey || ev.metaKey || ev.altKey || typing) return;
    ev.preventDefault();
    set(!held);
  });
  onStatus((s) => {
    if (!busy) show(Boolean(s.held));
    why.textContent = s.held_by === "session"
      ? ` for the controller session (CC) until it stops` : "";
    recognised.textContent = s.action ? s.action.label : "nothing (no navigator)";
  });
}
