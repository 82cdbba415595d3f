// The selected session: the participant's link (QR code, session-scoped credential), its summary
// (run time, time without a navigator, locomotion alarms), notes, the event log as a table with a
// filter per kind, and the corrections made (audit trail).

import { get, post, patch, toast, el } from "../api.js";
import { fmtDuration } from "./study.js";

function describe(e) {
  const p = e.payload || {};
  switch (e.kind) {
    case "session":
      if (p.state === "running")
        return `started · calibration ${p.calibration_id ?? "none"} · pose model ${p.pose_model} · action model ${p.action_model}` +
          (p.planned_duration_s ? ` · run ${fmtDuration(p.planned_duration_s)}` : "") +
          (p.held ? " · navigation held" : "");
      return `${p.state}${p.by ? ` (by ${p.by})` : ""}`;
    case "action":
      return `${p.previous ?? "–"} → ${p.label ?? "–"}${p.user_id != null ? ` (user ${p.user_id})` : ""}`;
    case "navigator":
      return p.message || `${p.previous ?? "none"} → ${p.current ?? "none"} (${p.mode})`;
    case "questionnaire":
      return `${p.instrument}${p.phase ? ` ${p.phase}` : ""} entry ${p.id} by ${p.entered_by}${p.corrects ? `, corrects entry ${p.corrects}: ${p.reason}` : ""}`;
    case "alarm":
      return p.state === "raised" ? `no locomotion command for > 2 s: ${p.reason}` : `locomotion again after ${Number(p.gap_s).toFixed(1)} s`;
    case "override":
      return `override of "${p.rule}": ${p.reason} (${p.message})`;
    case "correction":
      return `${p.what}: ${p.reason}`;
    default:
      return p.message || JSON.stringify(p);
  }
}

export function mountSession() {
  const panel = document.getElementById("session-panel");
  const tbody = document.querySelector("#session-events tbody");
  const audit = document.querySelector("#session-audit tbody");
  const filters = document.getElementById("event-filters");
  const summary = document.getElementById("session-summary");
  const linkBox = document.getElementById("session-link");
  const hidden = new Set(["action"]); // the kinds not shown (action events are many: off at first)
  let session = null;
  let events = [];

  function drawEvents() {
    const kinds = [...new Set(events.map((e) => e.kind))].sort();
    filters.replaceChildren(
      ...kinds.map((k) => {
        const box = el("input", { type: "checkbox", value: k, "data-kind": k });
        box.checked = !hidden.has(k);
        box.addEventListener("change", () => {
          if (box.checked) hidden.delete(k);
          else hidden.add(k);
          drawEvents();
        });
        return el("label", {}, box, ` ${k} (${events.filter((e) => e.kind === k).length})`);
      }),
    );
    tbody.replaceChildren(
      ...events
        .filter((e) => !hidden.has(e.kind))
        .slice(-300)
        .reverse()
        .map((e) =>
          el(
            "tr",
            { class: `kind-${e.kind}`, dataset: { kind: e.kind } },
            el("td", {}, new Date(e.ts * 1000).toLocaleTimeString()),
            el("td", {}, e.kind),
            el("td", {}, describe(e)),
          ),
        ),
    );
  }

  function drawSummary(s) {
    const row = (k, v, bad = false) => [el("dt", {}, k), el("dd", { class: bad ? "bad" : "" }, v)];
    summary.replaceChildren(
      el(
        "dl",
        { id: "summary-list" },
        ...row("run time", fmtDuration(s.duration_s)),
        ...row(
          "without a navigator",
          s.without_navigator_s == null ? "–" : `${fmtDuration(s.without_navigator_s)} (${Math.round(100 * (s.without_navigator_fraction || 0))} %)`,
          (s.without_navigator_s || 0) > 2,
        ),
        ...row(
          "navigation held",
          s.held_s == null ? "–" : s.holds ? `${fmtDuration(s.held_s)} (${s.holds} ${s.holds === 1 ? "hold" : "holds"})` : "never",
        ),
        ...row("locomotion alarms", `${s.locomotion_alarms} (${fmtDuration(s.locomotion_gap_s)})`, s.locomotion_alarms > 0),
        ...row("navigator changes", String(s.navigator_changes)),
        ...row("actions", Object.entries(s.actions_s).map(([k, v]) => `${k} ${fmtDuration(v)}`).join(", ") || "–"),
        ...row("questionnaires", `${s.questionnaires}${s.corrections ? ` (${s.corrections} corrected)` : ""}`),
        ...row("overrides", String(s.overrides), s.overrides > 0),
      ),
    );
  }

  async function refresh() {
    if (!session) return;
    const id = session.id;
    try {
      const [ev, sum, trail, entries] = await Promise.all([
        get(`/sessions/${id}/events?limit=5000`),
        get(`/sessions/${id}/summary`),
        get("/audit?limit=500"),
        get(`/sessions/${id}/questionnaires`),
      ]);
      if (!session || session.id !== id) return;
      events = ev;
      drawEvents();
      drawSummary(sum);
      const ids = new Set(entries.map((q) => q.id));
      const mine = trail.filter(
        (a) => (a.entity === "session" && a.entity_id === id) || (a.entity === "questionnaire" && ids.has(a.entity_id)),
      );
      audit.replaceChildren(
        ...mine.map((a) =>
          el(
            "tr",
            {},
            el("td", {}, new Date(a.at).toLocaleString()),
            el("td", {}, a.actor),
            el("td", {}, `${a.action} ${a.entity} ${a.entity_id}`),
            el("td", {}, a.reason),
          ),
        ),
      );
    } catch (err) {
      toast(`session ${id}: ${err.message}`);
    }
  }

  async function makeLink() {
    try {
      const link = await post(`/sessions/${session.id}/participant-link`);
      const qr = document.createElement("div");
      qr.innerHTML = link.qr_svg; // our own server's SVG (segno)
      linkBox.replaceChildren(
        qr,
        el(
          "div",
          {},
          el("div", {}, "Open on the participant's tablet (this session only):"),
          el("a", { id: "participant-url", href: link.url, target: "_blank", rel: "noopener" }, el("code", {}, link.url)),
          link.reachable_from_lan
            ? ""
            : el("div", { class: "warn" }, "The server listens on this computer only: start it with --host 0.0.0.0 (see README, study day) for a tablet to reach it."),
          el("button", { class: "secondary", onclick: makeLink }, "new link (the old one stops working)"),
        ),
      );
    } catch (err) {
      toast(`participant link: ${err.message}`);
    }
  }

  document.getElementById("session-notes-save").addEventListener("click", async () => {
    if (!session) return;
    try {
      await patch(`/sessions/${session.id}`, { notes: document.getElementById("session-notes").value });
      toast("notes saved", "ok");
    } catch (err) {
      toast(`notes: ${err.message}`);
    }
  });
  setInterval(() => {
    if (session && !document.hidden) refresh();
  }, 3000);

  return {
    show(s, { refreshOnly = false } = {}) {
      const changed = !session || session.id !== s.id;
      session = s;
      panel.hidden = false;
      document.getElementById("session-detail-id").textContent = `${s.id} (${s.participant_code}, ${s.condition}, ${s.status})`;
      if (changed || !refreshOnly) {
        document.getElementById("session-notes").value = s.notes;
        linkBox.replaceChildren(el("button", { id: "participant-link", onclick: makeLink }, "Participant link / QR code"));
        events = [];
        tbody.replaceChildren();
        refresh();
      }
    },
  };
}
