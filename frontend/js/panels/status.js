// Top bar and latency panel: pipeline state, fps, dropped frames, free disk space, per-stage latency, camera health;
// start/stop of the pipeline, and its restart when it does not use an accepted calibration or activated model yet.

import { post, toast, el } from "../api.js";
import { onStatus } from "../live.js";

const fmt = (v, d = 1) => (v === null || v === undefined ? "–" : Number(v).toFixed(d));

export function mountStatus() {
  const state = document.getElementById("state");
  const tbody = document.querySelector("#latency-table tbody");
  const health = document.getElementById("camera-health");
  const notice = document.getElementById("restart-notice");
  const NEW = { calibration: "the accepted calibration", model: "the activated action model" };
  onStatus((s) => {
    const waiting = (s.restart_for || []).map((w) => NEW[w] || w);
    notice.hidden = waiting.length === 0;
    document.getElementById("restart-what").textContent = waiting.length
      ? `The running pipeline does not use ${waiting.join(" or ")} until it starts again.` : "";
    state.textContent = s.state;
    state.dataset.state = s.state;
    document.getElementById("source").textContent = s.source || "–";
    document.getElementById("fps").textContent = fmt(s.fps);
    document.getElementById("dropped").textContent = s.dropped;
    document.getElementById("running-session").textContent = s.running_session_id ?? "none";
    const storage = s.storage || {};
    const disk = document.getElementById("disk");
    document.getElementById("disk-free").textContent = storage.free_gb == null ? "–" : `${fmt(storage.free_gb)} GB free`;
    disk.dataset.level = storage.level || "ok";
    disk.title = storage.message || "free disk space where the server writes (database, backups, takes)";
    tbody.replaceChildren(
      ...Object.entries(s.latency_ms || {}).map(([stage, q]) =>
        el("tr", {}, el("td", {}, stage), el("td", {}, fmt(q.p50)), el("td", {}, fmt(q.p95)), el("td", {}, fmt(q.p99))),
      ),
    );
    health.replaceChildren(
      ...(s.cameras || []).map((c) =>
        el("li", { class: c.ok ? "ok" : "bad", title: c.last_error || "" }, `${c.name} ${c.ok ? "ok" : "down"} ${fmt(c.fps)} fps`),
      ),
    );
  });
  document.getElementById("pipeline-start").addEventListener("click", async () => {
    const source = document.getElementById("source-select").value;
    try {
      await post("/pipeline/start", { source });
    } catch (err) {
      toast(`start failed: ${err.message}`);
    }
  });
  const restart = document.getElementById("pipeline-restart");
  restart.addEventListener("click", async () => {
    restart.disabled = true; // a second or two: the workers stop and start again
    restart.textContent = "Restarting…";
    try {
      await post("/pipeline/restart");
      toast("the pipeline started again", "ok");
    } catch (err) {
      toast(`restart failed: ${err.message}`);
    } finally {
      restart.disabled = false;
      restart.textContent = "Restart now";
    }
  });
  document.getElementById("pipeline-stop").addEventListener("click", async () => {
    try {
      await post("/pipeline/stop");
    } catch (err) {
      toast(`stop failed: ${err.message}`);
    }
  });
}
