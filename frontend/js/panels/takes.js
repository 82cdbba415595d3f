// Takes: record a take from the running pipeline (participant, protocol, duration, reaction margin),
// follow it (elapsed, frames, the participant's current prompt), stop it, and list the takes.

import { api, get, post, put, toast, el, withToken } from "../api.js";

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
  const videos = el("input", { id: "take-videos", type: "checkbox",
    title: "one MP4 per camera (cameras or video files; the simulator has no images)" });
  const start = el("button", { id: "take-start" }, "Record");
  const stop = el("button", { id: "take-stop", disabled: "" }, "Stop");
  const state = el("div", { id: "take-state", class: "take-state" }, "not recording");
  const promptLink = el("a", { id: "take-prompt-link", href: withToken("/prompt.html"), target: "_blank",
    rel: "noopener" }, "participant prompt page");
  const table = el("table", { id: "take-table" },
    el("thead", {}, el("tr", {}, ...["id", "take", "participant", "protocol", "status", "s", "frames", ""]
      .map((h) => el("th", {}, h)))),
    el("tbody"));
  root.replaceChildren(
    el("h2", {}, "Takes ", el("small", {}, promptLink)),
    el("div", { class: "row" }, code, protocol, el("label", {}, "duration ", duration),
      el("label", {}, "margin ", margin, " s"), el("label", {}, videos, " videos"), start, stop),
    state, table,
  );
  const editor = mountLabelEditor(root);
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
      el("td", {}, num(t.duration_s)), el("td", {}, t.frames),
      el("td", {}, ...(t.status === "recording" ? [] : [el("button", { class: "take-labels",
        onclick: () => editor.open(t) }, "labels"), ...exportLinks(t)])))));
  }

  // Downloads: the take's files + videos + TRC + labels table (zip), the participant's TRC
  // (Pose2Sim/OpenSim), the per-frame labels CSV (R/SPSS, when the take has labels).
  function exportLinks(t) {
    const link = (format, text, title) => el("a", { class: "take-export", dataset: { format },
      href: withToken(`/api/v1/takes/${t.id}/export?format=${format}`), download: "", title }, text);
    const links = [link("zip", "zip", "the take's files, videos, TRC and labels table"),
      link("trc", "TRC", "the participant's markers (metres, Y-up) for Pose2Sim / OpenSim")];
    if (t.files && t.files["labels.csv"]) links.push(link("labels", "CSV", "one row per frame (R, SPSS)"));
    return links;
  }

  function videoText(v) {
    if (!v) return "";
    const cams = Object.values(v);
    const written = cams.reduce((n, c) => n + c.written, 0);
    const dropped = cams.reduce((n, c) => n + c.dropped, 0);
    const errors = cams.filter((c) => c.error).map((c) => c.error);
    return `, videos: ${written} frames written${dropped ? `, ${dropped} dropped` : ""}`
      + (errors.length ? ` (${errors[0]})` : "");
  }

  async function poll() {
    try {
      const cur = await get("/takes/current");
      if (cur.recording) {
        current = cur;
        const p = cur.prompt;
        state.textContent = `recording take ${cur.take_id}: ${num(cur.elapsed_s)} / ${num(cur.duration_s, 0)} s, `
          + `${cur.frames} frames${cur.dropped ? `, ${cur.dropped} dropped` : ""}${videoText(cur.videos)}`
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
    if (videos.checked) body.videos = true;
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

const LABELS = ["still", "forward", "left", "right", "ignore"];

// The timeline label editor: the take's label spans on one track; drag the boundary between two
// spans, select a span and relabel it, then save (PUT /takes/{id}/labels).
function mountLabelEditor(root) {
  const track = el("div", { id: "label-track", class: "label-track" });
  const axis = el("div", { id: "label-axis", class: "label-axis" });
  const choice = el("select", { id: "label-choice", "aria-label": "label" },
    ...LABELS.map((l) => el("option", { value: l }, l)));
  const apply = el("button", { id: "label-apply" }, "Relabel span");
  const save = el("button", { id: "label-save", disabled: "" }, "Save labels");
  const info = el("span", { id: "label-info" });
  const title = el("h3", {}, "Labels");
  // the take replayed in the 3D view: a scrubber, play/pause, back to the live view
  const scrub = el("input", { id: "label-scrub", type: "range", min: "0", max: "1", step: "0.05", value: "0",
    "aria-label": "replay time", class: "label-scrub" });
  const play = el("button", { id: "label-play", title: "replay the take in the 3D view" }, "Play");
  const live = el("button", { id: "label-live", title: "the 3D view shows the live people again" }, "Live view");
  const replayInfo = el("span", { id: "label-replay", class: "label-replay" });
  const box = el("div", { id: "label-editor", hidden: "" }, title, track, axis,
    el("div", { class: "row" }, scrub, play, live, replayInfo),
    el("div", { class: "row" }, choice, apply, save, info));
  root.append(box);
  let take = null;
  let spans = [];
  let duration = 1;
  let selected = -1;

  const pct = (t) => `${(100 * t) / duration}%`;
  let playhead = null;
  let playing = null;
  let inFlight = false;
  let wanted = null;

  // Show the take at t s in the 3D view (the newest wish wins; one request at a time).
  async function seek(t) {
    wanted = t;
    scrub.value = String(t);
    if (playhead) playhead.style.left = pct(t);
    if (inFlight || !take) return;
    inFlight = true;
    try {
      while (wanted !== null) {
        const at = wanted;
        wanted = null;
        const got = await put(`/takes/${take.id}/replay`, { t_s: at });
        replayInfo.textContent = `3D view: ${num(got.frame_t_s, 2)} s, frame ${got.frame}, `
          + `users ${got.users.join(", ") || "none"}`;
        replayInfo.dataset.t = String(got.frame_t_s);
      }
    } catch (err) {
      replayInfo.textContent = `3D view: ${err.message}`;
      stopPlaying();
    } finally {
      inFlight = false;
    }
  }

  function stopPlaying() {
    if (playing) clearInterval(playing);
    playing = null;
    play.textContent = "Play";
  }

  scrub.addEventListener("input", () => { stopPlaying(); seek(Number(scrub.value)); });
  play.addEventListener("click", () => {
    if (playing) { stopPlaying(); return; }
    play.textContent = "Pause";
    let t = Number(scrub.value) >= duration - 0.05 ? 0 : Number(scrub.value);
    const t0 = performance.now() - t * 1000;
    playing = setInterval(() => {
      t = (performance.now() - t0) / 1000;
      if (t >= duration) { stopPlaying(); t = duration; }
      seek(Math.round(t * 100) / 100);
    }, 100);
  });
  live.addEventListener("click", async () => {
    stopPlaying();
    try {
      await api("DELETE", "/takes/replay");
      replayInfo.textContent = "3D view: live";
      delete replayInfo.dataset.t;
    } catch (err) {
      toast(`live view: ${err.message}`);
    }
  });

  function render() {
    track.replaceChildren();
    spans.forEach((s, i) => {
      const span = el("div", { class: `label-span${i === selected ? " selected" : ""}`,
        dataset: { index: i, label: s.label }, title: `${s.label} ${num(s.t_start, 2)}–${num(s.t_end, 2)} s${s.tag ? ` (${s.tag})` : ""}` },
        s.label);
      span.style.left = pct(s.t_start);
      span.style.width = pct(s.t_end - s.t_start);
      span.addEventListener("click", () => {
        selected = i;
        choice.value = s.label;
        render();
      });
      track.append(span);
      const nextSpan = spans[i + 1];
      if (nextSpan && Math.abs(nextSpan.t_start - s.t_end) < 1e-6) {
        const handle = el("div", { class: "label-handle", dataset: { index: i },
          title: "drag to move this boundary" });
        handle.style.left = pct(s.t_end);
        handle.addEventListener("pointerdown", (ev) => startDrag(ev, i, handle));
        track.append(handle);
      }
    });
    axis.textContent = `0 s … ${num(duration, 1)} s`;
    playhead = el("div", { id: "label-playhead", class: "label-playhead" });
    playhead.style.left = pct(Number(scrub.value));
    track.append(playhead);
  }

  function startDrag(ev, i, handle) {
    ev.preventDefault();
    handle.setPointerCapture(ev.pointerId);
    const rect = track.getBoundingClientRect();
    const move = (e) => {
      const t = ((e.clientX - rect.left) / rect.width) * duration;
      const lo = spans[i].t_start + 0.05;
      const hi = spans[i + 1].t_end - 0.05;
      const v = Math.round(Math.min(hi, Math.max(lo, t)) * 1000) / 1000;
      spans[i].t_end = v;
      spans[i + 1].t_start = v;
      spans[i].source = "operator";
      spans[i + 1].source = "operator";
      dirty();
      render();
      seek(v);  // the 3D view shows the moment of the boundary being dragged
    };
    const up = () => {
      window.removeEventListener("pointermove", move);
      window.removeEventListener("pointerup", up);
    };
    window.addEventListener("pointermove", move);
    window.addEventListener("pointerup", up);
  }

  function dirty() {
    save.disabled = false;
    info.textContent = "unsaved changes";
  }

  apply.addEventListener("click", () => {
    if (selected < 0) {
      toast("select a span first");
      return;
    }
    spans[selected].label = choice.value;
    spans[selected].source = "operator";
    dirty();
    render();
  });
  save.addEventListener("click", async () => {
    try {
      const body = { spans: spans.map((s) => ({ t_start: s.t_start, t_end: s.t_end, label: s.label,
        user_id: s.user_id, tag: s.tag || "", source: s.source || "operator" })) };
      const got = await put(`/takes/${take.id}/labels`, body);
      spans = got.spans;
      save.disabled = true;
      info.textContent = "saved";
      render();
    } catch (err) {
      toast(`labels: ${err.message}`);
    }
  });

  return {
    async open(t) {
      take = t;
      const got = await get(`/takes/${t.id}/labels`);
      spans = got.spans;
      duration = Math.max(got.duration_s || 0, ...spans.map((s) => s.t_end), 0.1);
      stopPlaying();
      scrub.max = String(duration);
      scrub.value = "0";
      replayInfo.textContent = "";
      selected = -1;
      title.textContent = `Labels of take ${t.id} (${t.uid})`;
      box.hidden = false;
      box.dataset.takeId = t.id;
      save.disabled = true;
      info.textContent = spans.length ? "" : "no labels (a take without a protocol)";
      render();
    },
  };
}
