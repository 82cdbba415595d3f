// Action models: the registry (each model with its card; activate one, roll back to the one before,
// register a model file), fine-tuning on labelled takes in a worker with its progress, and the
// participants' teach adaptations (switch one on or off).

import { get, post, patch, toast, el, token } from "../api.js";

function short(sha) {
  return sha ? sha.slice(0, 10) : "–";
}

function fixed(x, digits = 3) {
  return typeof x === "number" ? x.toFixed(digits) : "–";
}

function fileBase64(file) {
  return new Promise((resolve, reject) => {
    const reader = new FileReader();
    reader.onload = () => resolve(String(reader.result).split(",", 2)[1] || "");
    reader.onerror = () => reject(reader.error);
    reader.readAsDataURL(file);
  });
}

export function mountModels(root) {
  root.hidden = false;
  const table = el("table", { id: "model-table" },
    el("thead", {}, el("tr", {}, ...["id", "name", "kind", "sha256", "created", "LOSO acc.", "", ""]
      .map((h) => el("th", {}, h)))),
    el("tbody"));
  const rollback = el("button", { id: "model-rollback" }, "Roll back");
  const file = el("input", { id: "model-file", type: "file", accept: ".onnx" });
  const upload = el("button", { id: "model-upload" }, "Register file");
  const card = el("pre", { id: "model-card", class: "model-card", hidden: "" });
  const active = el("div", { id: "model-active" }, "");
  const train = mountTraining(() => refresh());
  const teach = mountTeach();
  root.replaceChildren(
    el("h2", {}, "Action models"),
    active,
    table,
    el("div", { class: "row" }, rollback, file, upload),
    card,
    train.node,
    teach.node,
  );

  async function refresh() {
    const models = await get("/models");
    const on = models.find((m) => m.active);
    active.textContent = on ? `active: model ${on.id} — ${on.name} (${on.kind}, sha256 ${short(on.sha256)})` : "";
    table.tBodies[0].replaceChildren(...models.slice().reverse().map((m) => el("tr",
      { dataset: { modelId: m.id, active: m.active ? "true" : "false" } },
      el("td", {}, m.id), el("td", {}, m.name), el("td", {}, m.kind), el("td", { class: "mono" }, short(m.sha256)),
      el("td", {}, new Date(m.created_at).toLocaleString()),
      el("td", {}, fixed((m.card.figures || {}).loso_accuracy)),
      el("td", {}, el("button", { class: "model-card-button", onclick: () => showCard(m) }, "card")),
      el("td", {}, m.active ? el("strong", {}, "active")
        : el("button", { class: "model-activate", onclick: () => activate(m.id) }, "activate")))));
  }

  async function showCard(m) {
    try {
      const res = await fetch(`/api/v1/models/${m.id}/card.md`, { headers: authHeaders() });
      const text = await res.text();
      card.textContent = text || JSON.stringify(m.card, null, 1);
      card.hidden = false;
      card.dataset.modelId = m.id;
    } catch (err) {
      toast(`card: ${err.message}`);
    }
  }

  async function activate(id) {
    try {
      await post(`/models/${id}/activate`);
      toast(`model ${id} is active (the pipeline runs it from its next start)`, "ok");
    } catch (err) {
      toast(`activate: ${err.message}`);
    }
    await refresh();
  }

  rollback.addEventListener("click", async () => {
    try {
      const m = await post("/models/rollback");
      toast(`rolled back to model ${m.id}`, "ok");
    } catch (err) {
      toast(`roll back: ${err.message}`);
    }
    await refresh();
  });

  upload.addEventListener("click", async () => {
    const f = file.files && file.files[0];
    if (!f) {
      toast("choose an .onnx file first");
      return;
    }
    try {
      const m = await post("/models", { name: f.name, onnx_base64: await fileBase64(f) });
      toast(`registered model ${m.id}`, "ok");
    } catch (err) {
      toast(`register: ${err.message}`);
    }
    await refresh();
  });

  refresh().catch((err) => toast(`models: ${err.message}`));
  return { refresh };
}

// Fine-tuning: choose labelled takes, run `cavewalk train` in the server's worker, follow its progress.
function mountTraining(onDone) {
  const takes = el("div", { id: "train-takes", class: "row" });
  const epochs = el("input", { id: "train-epochs", type: "number", min: "1", max: "50", value: "2", class: "narrow" });
  const sim = el("input", { id: "train-sim", type: "number", min: "0", max: "400", value: "8", class: "narrow" });
  const windows = el("input", { id: "train-windows", type: "number", min: "256", max: "100000", value: "4096",
    class: "narrow", title: "training windows per epoch" });
  const start = el("button", { id: "train-start" }, "Fine-tune on the chosen takes");
  const bar = el("progress", { id: "train-progress", class: "train-progress", max: "1", value: "0" });
  const state = el("div", { id: "train-state" }, "no training job");
  const logBox = el("pre", { id: "train-log", class: "train-log" });
  const node = el("div", { id: "train-section" },
    el("h3", {}, "Fine-tune on takes"), takes,
    el("div", { class: "row" }, el("label", {}, "epochs ", epochs), el("label", {}, "simulated routines ", sim),
      el("label", {}, "windows/epoch ", windows), start),
    bar, state, logBox);
  let job = null;
  let timer = null;

  async function loadTakes() {
    const rows = (await get("/takes")).filter((t) => t.status !== "recording");
    takes.replaceChildren(...(rows.length ? rows.map((t) => el("label", { class: "train-take" },
      el("input", { type: "checkbox", value: t.id, dataset: { takeId: t.id } }),
      ` ${t.id}: ${t.participant_code || t.uid} (${t.protocol || "no protocol"})`))
      : [el("span", {}, "no takes yet: record some with a protocol")]));
  }

  function show(j) {
    job = j;
    bar.value = j.progress;
    state.textContent = `job ${j.id}: ${j.state} — ${j.message}`;
    state.dataset.state = j.state;
    logBox.textContent = j.log.join("\n");
    start.disabled = j.state === "running";
  }

  async function poll() {
    if (!job) return;
    try {
      show(await get(`/models/train/${job.id}`));
    } catch (err) {
      state.textContent = `training: ${err.message}`;
    }
    if (job.state !== "running") {
      clearInterval(timer);
      timer = null;
      onDone();
    }
  }

  start.addEventListener("click", async () => {
    const ids = [...takes.querySelectorAll("input:checked")].map((i) => Number(i.value));
    if (!ids.length) {
      toast("choose at least one labelled take");
      return;
    }
    try {
      show(await post("/models/train", { take_ids: ids, epochs: Number(epochs.value), sim_routines: Number(sim.value),
        windows_per_epoch: Number(windows.value) }));
      timer = timer || setInterval(poll, 700);
    } catch (err) {
      toast(`fine-tune: ${err.message}`);
      state.textContent = `not started: ${err.message}`;
      state.dataset.state = "refused";
    }
  });

  loadTakes().catch((err) => toast(`takes: ${err.message}`));
  return { node, refresh: loadTakes };
}

// Teach: adapt the active model to the participant of a teach take; accuracy before / after on the
// held-back part; switch each participant's adaptation on or off (it applies to their sessions only).
function mountTeach() {
  const take = el("select", { id: "teach-take", "aria-label": "teach take" });
  const start = el("button", { id: "teach-start" }, "Teach");
  const result = el("div", { id: "teach-result" }, "");
  const table = el("table", { id: "adaptation-table" },
    el("thead", {}, el("tr", {}, ...["id", "participant", "model", "take", "held-back accuracy", "on", ""]
      .map((h) => el("th", {}, h)))),
    el("tbody"));
  const node = el("div", { id: "teach-section" },
    el("h3", {}, "Teach (adapt to one participant)"),
    el("div", { class: "row" }, take, start), result, table);

  async function loadTakes() {
    const rows = (await get("/takes")).filter((t) => t.status !== "recording" && t.participant_code);
    take.replaceChildren(...rows.slice().reverse().map((t) => el("option", { value: t.id },
      `${t.id}: ${t.participant_code} (${t.protocol || "no protocol"})`)));
  }

  async function refresh() {
    const rows = await get("/models/adaptations");
    table.tBodies[0].replaceChildren(...rows.slice().reverse().map((a) => el("tr",
      { dataset: { adaptationId: a.id, enabled: a.enabled ? "true" : "false" } },
      el("td", {}, a.id), el("td", {}, a.participant_code), el("td", {}, a.model_id), el("td", {}, a.take_id ?? "–"),
      el("td", {}, `${fixed(a.report.before.accuracy)} → ${fixed(a.report.after.accuracy)}`),
      el("td", {}, a.enabled ? "on" : "off"),
      el("td", {}, el("button", { class: "adaptation-toggle", onclick: () => toggle(a) },
        a.enabled ? "switch off" : "switch on")))));
  }

  async function toggle(a) {
    try {
      await patch(`/models/adaptations/${a.id}`, { enabled: !a.enabled });
    } catch (err) {
      toast(`teach: ${err.message}`);
    }
    await refresh();
  }

  start.addEventListener("click", async () => {
    if (!take.value) {
      toast("record a teach take (protocol teach) with a participant code first");
      return;
    }
    result.textContent = "fitting…";
    try {
      const a = await post("/models/teach", { take_id: Number(take.value) });
      const r = a.report;
      result.textContent = `participant ${a.participant_code}: held-back accuracy ${fixed(r.before.accuracy)} → `
        + `${fixed(r.after.accuracy)} (${r.holdout_frames} frames from ${r.split_s} s); `
        + (a.enabled ? "switched on for their sessions" : "not switched on: it did not help on the held-back part");
      result.dataset.adaptationId = a.id;
    } catch (err) {
      result.textContent = `teach: ${err.message}`;
      toast(`teach: ${err.message}`);
    }
    await refresh();
  });

  loadTakes().catch((err) => toast(`takes: ${err.message}`));
  refresh().catch((err) => toast(`adaptations: ${err.message}`));
  return { node, refresh };
}

function authHeaders() {
  return token() ? { Authorization: `Bearer ${token()}` } : {};
}
