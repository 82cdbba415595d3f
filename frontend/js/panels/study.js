// The study panel: participants (pseudonymous codes, counterbalanced order), planned sessions,
// start/stop, notes and the session's event log. Selecting a session mounts the questionnaire forms.

import { get, post, patch, toast, el } from "../api.js";

export function mountStudy({ onSelectSession }) {
  const codeInput = document.getElementById("participant-code");
  const ptable = document.querySelector("#participant-table tbody");
  const stable = document.querySelector("#session-table tbody");
  const psel = document.getElementById("session-participant");
  const detail = document.getElementById("session-detail");
  let selected = null;

  async function refresh() {
    const [participants, sessions] = await Promise.all([get("/participants"), get("/sessions")]);
    ptable.replaceChildren(
      ...participants.map((p) => {
        const mine = sessions.filter((s) => s.participant_id === p.id);
        const order = p.first_condition ? `${p.first_condition} first` : "–";
        return el("tr", {}, el("td", {}, p.code), el("td", {}, order), el("td", {}, mine.map((s) => `${s.condition}:${s.status}`).join(", ")));
      }),
    );
    const keep = psel.value;
    psel.replaceChildren(...participants.map((p) => el("option", { value: p.id }, p.code)));
    if (keep) psel.value = keep;
    stable.replaceChildren(
      ...sessions.map((s) =>
        el(
          "tr",
          { class: s.id === selected ? "selected" : "", dataset: { sessionId: s.id } },
          el("td", {}, s.id),
          el("td", {}, s.participant_code),
          el("td", {}, s.condition),
          el("td", {}, s.planned_index ?? "–"),
          el("td", { class: `status ${s.status}` }, s.status),
          el(
            "td",
            {},
            s.status === "planned" ? el("button", { class: "session-start", onclick: () => act(s.id, "start") }, "start") : "",
            s.status === "running" ? el("button", { class: "session-stop", onclick: () => act(s.id, "stop") }, "stop") : "",
            el("button", { class: "session-select", onclick: () => select(s) }, "select"),
          ),
        ),
      ),
    );
  }

  async function act(id, what) {
    try {
      await post(`/sessions/${id}/${what}`);
    } catch (err) {
      toast(`session ${id}: ${err.message}`);
    }
    await refresh();
    if (selected === id) await showEvents(id);
  }

  async function showEvents(id) {
    const events = await get(`/sessions/${id}/events?limit=200`);
    document.getElementById("session-events").replaceChildren(
      ...events.slice(-200).map((e) =>
        el("div", { class: `event ${e.kind}` }, `${new Date(e.ts * 1000).toLocaleTimeString()} ${e.kind} ${JSON.stringify(e.payload)}`),
      ),
    );
  }

  async function select(session) {
    selected = session.id;
    detail.hidden = false;
    document.getElementById("session-detail-id").textContent = `${session.id} (${session.participant_code}, ${session.condition})`;
    document.getElementById("session-notes").value = session.notes;
    await refresh();
    await showEvents(session.id);
    onSelectSession(session);
  }

  document.getElementById("participant-add").addEventListener("click", async () => {
    try {
      await post("/participants", { code: codeInput.value.trim() });
      codeInput.value = "";
    } catch (err) {
      toast(`participant: ${err.message}`);
    }
    await refresh();
  });
  document.getElementById("session-add").addEventListener("click", async () => {
    const participant_id = Number(psel.value);
    if (!participant_id) {
      toast("add a participant first");
      return;
    }
    try {
      await post("/sessions", { participant_id, condition: document.getElementById("session-condition").value });
    } catch (err) {
      toast(`session: ${err.message}`);
    }
    await refresh();
  });
  document.getElementById("session-notes-save").addEventListener("click", async () => {
    if (selected === null) return;
    try {
      await patch(`/sessions/${selected}`, { notes: document.getElementById("session-notes").value });
      toast("notes saved", "ok");
    } catch (err) {
      toast(`notes: ${err.message}`);
    }
  });
  setInterval(() => {
    if (selected !== null && !document.hidden) showEvents(selected).catch(() => {});
  }, 3000);
  refresh().catch((err) => toast(`study: ${err.message}`));
}
