// Takes: record a take from the running pipeline (participant, protocol, duration, reaction margin),
// follow it (elapsed, frames, the participant's current prompt), stop it, and list the takes.

import { get, post, toast, el, withToken } from "../api.js";

function num(x, digits = 1) {
  return x === null || x === undefined ? "–" : Number(x).toFixed(digits);
}

export function mountTakes(root) {
  root.hidden = false;
  const protocol = el("select", { id: "take-protocol", "aria-label": "protocol" },
    el("option", { value: "" }, "no protocol (duration only)"));
  const code = el("input", { id: "take-participant", placeholder: "participant code", maxlength: "32",
    pattern: "[A-Za-z0-9_-]{1,32}", class: "narrow" });
  const duration = el("input", { id: "take-duration", type: "number", min: "1", max: "3600", step: "1",
    placeholder: "s", class: "narrow", title: "seconds (empty: the protocol's length)" });
  const margin = el("input", { id: "take-margin", type: "number", min: "0", max: "5", step: "0.1",
    value: "0.5", class: "narrow", title: "reaction margin: seconds labelled ignore after each change" });
  const start = el("button", { id: "take-start" }, "Record");
  const stop = el("button", { id: "take-stop", disabled: "" }, "Stop");
  const state = el("div", { id: "take-state", class: "take-state" }, "not recording");
  const promptLink = el("a", { id: "take-prompt-link", href: withToken("/prompt.html"), target: "_blank",
    rel: "noopener" }, "participant prompt page");
  const table = el("table", { id: "take-table" },
    el("thead", {}, el("tr", {}, ...["id", "take", "participant", "protocol", "status", "s", "frames"]
      .map((h) => el("th", {}, h)))),
    el("tbody"));
  root.replaceChildren(
    el("h2", {}, "Takes ", el("small", {}, promptLink)),
    el("div", { class: "row" }, code, protocol, el("label", {}, "duration ", duration),
      el("label", {}, "margin ", margin, " s"), start, stop),
    state, table,
  );
  let current = null;

  async function loadProtocols() {
    try {
      for (const p of await get("/protocols")) {
        protocol.append(el("option", { value: p.file }, `${p.name} (${num(p.duration_s, 0)} s)`));
      }
    } catch (err) {
      toast(`protocols: ${err.message}`);
    }
  }

  async function refreshTable() {
    const takes = await get("/takes");
    const body = table.tBodies[0];
    body.replaceChildren(...takes.slice().reverse().map((t) => el("tr", { dataset: { takeId: t.id, status: t.status } },
      el("td", {}, t.id), el("td", {}, t.uid), el("td", {}, t.participant_code || "–"),
      el("td", {}, t.protocol || "–"), el("td", { class: "status" }, t.status),
      el("td", {}, num(t.duration_s)), el("td", {}, t.frames))));
  }

  async function poll() {
    try {
      const cur = await get("/takes/current");
      if (cur.recording) {
        current = cur;
        const p = cur.prompt;
        state.textContent = `recording take ${cur.take_id}: ${num(cur.elapsed_s)} / ${num(cur.duration_s, 0)} s, `
          + `${cur.frames} frames${cur.dropped ? `, ${cur.dropped} dropped` : ""}`
          + (p ? ` — step ${p.index + 1}/${p.steps}: “${p.text}” (${p.label}), ${num(p.remaining_s)} s left` : "");
        state.dataset.recording = "true";
        start.disabled = true;
        stop.disabled = false;
      } else {
        if (current) await refreshTable();
        current = null;
        state.textContent = "not recording";
        state.dataset.recording = "false";
        start.disabled = false;
        stop.disabled = true;
      }
    } catch (err) {
      state.textContent = `takes: ${err.message}`;
    }
  }

  start.addEventListener("click", async () => {
    const body = { margin_s: Number(margin.value) };
    if (code.value) body.participant_code = code.value;
    if (protocol.value) body.protocol = protocol.value;
    if (duration.value) body.duration_s = Number(duration.value);
    try {
      await post("/takes", body);
      await poll();
      await refreshTable();
    } catch (err) {
      toast(`record: ${err.message}`);
    }
  });
  stop.addEventListener("click", async () => {
    if (!current) return;
    try {
      await post(`/takes/${current.take_id}/stop`);
    } catch (err) {
      toast(`stop: ${err.message}`);
    }
    await poll();
    await refreshTable();
  });

  loadProtocols();
  refreshTable().catch((err) => toast(`takes: ${err.message}`));
  poll();
  setInterval(poll, 500);
  return { refresh: refreshTable };
}
