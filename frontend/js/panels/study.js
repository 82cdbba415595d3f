// The study panel: plan all sessions for N participants at once (Latin square, with an override),
// or one participant / one session by hand; the participants and sessions with start times and run
// times; start/stop; exclusions and deletions with a reason; the database's last backup and
// *Back up now*. Selecting a session hands it on at once
// (the questionnaire form, the session panel and the script follow it).

import { get, post, patch, del, toast, el } from "../api.js";

const fmtTime = (iso) => (iso ? new Date(iso).toLocaleString([], { dateStyle: "short", timeStyle: "short" }) : "–");

export function fmtDuration(seconds) {
  if (seconds == null) return "–";
  const s = Math.round(seconds);
  return s >= 60 ? `${Math.floor(s / 60)} min ${String(s % 60).padStart(2, "0")} s` : `${s} s`;
}

function runTime(s) {
  if (s.status === "stopped") return `${fmtDuration(s.duration_s)}${s.stopped_by === "timer" ? " (auto-stop)" : ""}`;
  if (s.status === "running") return s.planned_duration_s ? `running, ${fmtDuration(s.planned_duration_s)} planned` : "running";
  return s.planned_duration_s ? `${fmtDuration(s.planned_duration_s)} planned` : "by hand";
}

function reasonFor(what) {
  const reason = window.prompt(`Reason to ${what} (kept in the audit trail):`);
  if (reason === null) return null;
  if (reason.trim().length < 3) {
    toast("a reason needs at least 3 characters");
    return null;
  }
  return reason.trim();
}

export function mountStudy({ onSelectSession }) {
  const codeInput = document.getElementById("participant-code");
  const ptable = document.querySelector("#participant-table tbody");
  const stable = document.querySelector("#session-table tbody");
  const psel = document.getElementById("session-participant");
  let selected = null;
  let sessions = [];

  async function act(path, body, what) {
    try {
      await post(path, body);
    } catch (err) {
      toast(`${what}: ${err.message}`);
    }
    await refresh();
  }

  async function withReason(what, method, path) {
    const reason = reasonFor(what);
    if (reason === null) return;
    try {
      if (method === "DELETE") await del(path, { reason });
      else await post(path, { reason });
    } catch (err) {
      toast(`${what}: ${err.message}`);
    }
    await refresh();
  }

  async function rename(p) {
    const code = window.prompt(`Corrected code for ${p.code}:`, p.code);
    if (code === null || code.trim() === "" || code.trim() === p.code) return;
    const reason = reasonFor(`rename ${p.code} to ${code.trim()}`);
    if (reason === null) return;
    try {
      await patch(`/participants/${p.id}`, { code: code.trim(), reason });
    } catch (err) {
      toast(`rename ${p.code}: ${err.message}`);
    }
    await refresh();
  }

  const backupState = document.getElementById("backup-state");
  const reasons = { "session-end": "session end", "before-upgrade": "before an upgrade", "before-restore": "before a restore", auto: "timed" };

  function showBackups(b) {
    // the last backup (or its failure), how many are kept and where: an experimenter sees the data is safe
    const kept = `${b.backups.length} kept in ${b.folder}`;
    if (b.last_error) {
      backupState.textContent = `Backup FAILED: ${b.last_error} (${kept})`;
    } else if (!b.enabled) {
      backupState.textContent = `Automatic backups are off (backup.enabled); ${kept}`;
    } else {
      const newest = b.last ?? b.backups[0];
      backupState.textContent = newest
        ? `Last backup ${fmtTime(newest.created)} (${reasons[newest.reason] ?? newest.reason}); ${kept}`
        : `No backup yet; ${kept}`;
    }
    if (b.same_disk) {
      backupState.append(document.createTextNode(" — on the database's own disk: they do not survive it; "
        + "copy the folder off this computer after the study day (or set backup.folder to another disk)"));
    }
    backupState.dataset.sameDisk = b.same_disk ? "true" : "false";
    backupState.classList.toggle("failed", Boolean(b.last_error));
  }

  async function refresh() {
    // the backups line on its own: a failure there must not stop the participants and sessions
    get("/backups")
      .then(showBackups)
      .catch((err) => {
        backupState.textContent = `backups: ${err.message}`;
        backupState.classList.add("failed");
      });
    const [participants, all] = await Promise.all([get("/participants"), get("/sessions")]);
    sessions = all;
    ptable.replaceChildren(
      ...participants.map((p) => {
        const mine = sessions.filter((s) => s.participant_id === p.id);
        const out = p.excluded_at !== null && p.excluded_at !== undefined;
        return el(
          "tr",
          { class: out ? "excluded" : "", title: out ? `excluded: ${p.exclusion_reason}` : "" },
          el("td", {}, p.code),
          el("td", {}, p.first_condition ? `${p.first_condition} first` : "–"),
          el("td", {}, mine.map((s) => `${s.condition}:${s.status}`).join(", ") || "–"),
          el(
            "td",
            {},
            el("button", { class: "secondary participant-rename", title: "correct the code (with a reason)", onclick: () => rename(p) }, "rename"),
            out
              ? el("button", { class: "secondary", onclick: () => withReason(`include ${p.code} again`, "POST", `/participants/${p.id}/include`) }, "include")
              : el("button", { class: "danger participant-exclude", onclick: () => withReason(`exclude ${p.code}`, "POST", `/participants/${p.id}/exclude`) }, "exclude"),
            mine.some((s) => s.started_at)
              ? ""
              : el("button", { class: "danger", onclick: () => withReason(`delete ${p.code}`, "DELETE", `/participants/${p.id}`) }, "delete"),
          ),
        );
      }),
    );
    const keep = psel.value;
    psel.replaceChildren(...participants.filter((p) => !p.excluded_at).map((p) => el("option", { value: p.id }, p.code)));
    if (keep) psel.value = keep;
    stable.replaceChildren(
      ...sessions.map((s) => {
        const out = s.excluded_at !== null && s.excluded_at !== undefined;
        return el(
          "tr",
          {
            class: `${s.id === selected ? "selected" : ""} ${out ? "excluded" : ""}`,
            dataset: { sessionId: s.id },
            title: out ? `excluded: ${s.exclusion_reason}` : "",
          },
          el("td", {}, s.id),
          el("td", {}, s.participant_code),
          el("td", {}, s.condition),
          el("td", {}, s.planned_index ?? "–"),
          el("td", { class: `status ${s.status}` }, out ? `${s.status} (excluded)` : s.status),
          el("td", {}, fmtTime(s.started_at)),
          el("td", { class: "run-time" }, runTime(s)),
          el(
            "td",
            {},
            el("button", { class: "session-select secondary", onclick: () => select(s) }, "select"),
            s.status === "planned" && !out ? el("button", { class: "session-start", onclick: () => act(`/sessions/${s.id}/start`, undefined, `session ${s.id}`) }, "start") : "",
            s.status === "running" ? el("button", { class: "session-stop", onclick: () => act(`/sessions/${s.id}/stop`, undefined, `session ${s.id}`) }, "stop") : "",
            s.status !== "running" && !out ? el("button", { class: "danger session-exclude", onclick: () => withReason(`exclude session ${s.id}`, "POST", `/sessions/${s.id}/exclude`) }, "exclude") : "",
            out ? el("button", { class: "secondary", onclick: () => withReason(`include session ${s.id} again`, "POST", `/sessions/${s.id}/include`) }, "include") : "",
            s.status === "planned" ? el("button", { class: "danger", onclick: () => withReason(`delete session ${s.id}`, "DELETE", `/sessions/${s.id}`) }, "delete") : "",
          ),
        );
      }),
    );
    if (selected !== null) {
      const current = sessions.find((s) => s.id === selected);
      if (current) onSelectSession(current, { refreshOnly: true });
    }
  }

  function select(session) {
    // hand the session on first: the form on screen is this session's from the first moment
    selected = session.id;
    onSelectSession(session, { refreshOnly: false });
    for (const tr of stable.querySelectorAll("tr")) tr.classList.toggle("selected", Number(tr.dataset.sessionId) === selected);
  }

  document.getElementById("plan-create").addEventListener("click", async () => {
    const n = Number(document.getElementById("plan-n").value);
    const minutes = Number(document.getElementById("plan-minutes").value);
    const orders = document.getElementById("plan-orders").value.trim().toUpperCase().split(/[\s,]+/).filter(Boolean);
    const body = { participants: n, code_prefix: document.getElementById("plan-prefix").value.trim() || "P" };
    if (minutes > 0) body.run_minutes = minutes;
    else body.run_minutes = null;
    if (orders.length) body.first_conditions = orders;
    try {
      const res = await post("/study/plan", body);
      toast(`planned ${res.participants.length} participants, ${2 * res.participants.length} sessions`, "ok");
    } catch (err) {
      toast(`plan: ${err.message}`);
    }
    await refresh();
  });
  document.getElementById("participant-add").addEventListener("click", async () => {
    await act("/participants", { code: codeInput.value.trim() }, "participant");
    codeInput.value = "";
  });
  document.getElementById("session-add").addEventListener("click", async () => {
    const participant_id = Number(psel.value);
    if (!participant_id) {
      toast("add a participant first");
      return;
    }
    await act("/sessions", { participant_id, condition: document.getElementById("session-condition").value }, "session");
  });
  document.getElementById("backup-now").addEventListener("click", async () => {
    try {
      const made = await post("/backups");
      toast(`backed up: ${made.name}`, "ok");
    } catch (err) {
      toast(`backup: ${err.message}`);
    }
    await refresh();
  });
  setInterval(() => {
    if (!document.hidden) refresh().catch(() => {});
  }, 5000);
  refresh().catch((err) => toast(`study: ${err.message}`));
  return { refresh, sessions: () => sessions };
}
