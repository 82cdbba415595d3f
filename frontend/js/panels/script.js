// The session script of the selected (or else the running) session: SSQ pre -> run (countdown,
// stopped by the server) -> SSQ post -> IPQ -> NASA-TLX, each step's state.

import { get, el } from "../api.js";
import { onStatus } from "../live.js";

function clock(seconds) {
  const s = Math.max(0, Math.round(seconds));
  return `${Math.floor(s / 60)}:${String(s % 60).padStart(2, "0")}`;
}

export function mountScript() {
  const list = document.getElementById("run-steps");
  const title = document.getElementById("run-session");
  const countdown = document.getElementById("run-countdown");
  let chosen = null;
  let running = null;
  let deadline = null; // local clock of the run's end

  async function refresh() {
    const id = chosen ?? running;
    if (id == null) {
      title.textContent = "no session selected";
      list.replaceChildren();
      countdown.hidden = true;
      return;
    }
    let script;
    try {
      script = await get(`/sessions/${id}/script`);
    } catch {
      return;
    }
    title.textContent = `session ${id} (${script.condition})${script.complete ? ": complete" : ""}`;
    const run = script.steps.find((s) => s.kind === "run");
    deadline = run && run.state === "running" && run.remaining_s != null ? performance.now() + 1000 * run.remaining_s : null;
    list.replaceChildren(
      ...script.steps.map((s) =>
        el(
          "li",
          { dataset: { state: s.state, key: s.key } },
          el("span", {}, s.label),
          el(
            "span",
            {},
            s.kind === "run"
              ? s.state === "done"
                ? `done, ${clock(s.elapsed_s)}`
                : s.planned_duration_s
                  ? `${clock(s.planned_duration_s)}${s.state === "running" ? " — auto-stop" : ""}`
                  : "stop by hand"
              : s.state === "done"
                ? `entry ${s.entry_id}`
                : s.state,
          ),
        ),
      ),
    );
    tick();
  }

  function tick() {
    countdown.hidden = deadline === null;
    if (deadline !== null) countdown.textContent = clock((deadline - performance.now()) / 1000);
  }

  onStatus((s) => {
    if (s.running_session_id !== running) {
      running = s.running_session_id;
      refresh();
    }
  });
  setInterval(tick, 250);
  setInterval(() => {
    if (!document.hidden) refresh();
  }, 2000);
  return {
    show(session) {
      chosen = session.id;
      refresh();
    },
    refresh,
  };
}
