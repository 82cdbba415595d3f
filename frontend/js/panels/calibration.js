// Calibration: start a run, follow its progress; a finished run is reviewed before it is used: its
// overlays large, its per-camera figures beside the active run's, then "Accept" (or keep the active
// one). History with roll back.

import { get, post, toast, el, withToken } from "../api.js";

const px = (v) => (v == null ? "–" : Number(v).toFixed(2));

function rmsText(run) {
  return run.cameras.map((c) => `${c.name} ${px(c.rms_px)} (${c.verdict || "?"})`).join(", ");
}

function overlayFigure(runId, c) {
  return el(
    "figure",
    { class: "overlay" },
    el("img", { src: withToken(`/api/v1/calibration/runs/${runId}/overlays/${c.name}.png`), alt: `${c.name} overlay of run ${runId}` }),
    el("figcaption", {}, `${c.name}: ${px(c.rms_px)} px, ${c.verdict || ""}`),
  );
}

export function mountCalibration(info) {
  const progress = document.getElementById("calibration-progress");
  const message = document.getElementById("calibration-message");
  const tbody = document.querySelector("#calibration-runs tbody");
  const overlays = document.getElementById("calibration-overlays");
  const review = document.getElementById("calibration-review");
  let polling = null;
  let reviewed = null;

  document.getElementById("calibration-patterns").replaceChildren(
    el("span", {}, "wall patterns: "),
    ...info.walls.map((w) => el("a", { href: withToken(`/api/v1/calibration/patterns/${w}.png`), target: "_blank" }, w)),
  );

  function showOverlays(run) {
    overlays.replaceChildren(...run.cameras.map((c) => overlayFigure(run.id, c)));
  }

  async function showReview(run) {
    if (reviewed === run.id) return;
    reviewed = run.id;
    let cmp;
    try {
      cmp = await get(`/calibration/runs/${run.id}/compare`);
    } catch (err) {
      toast(`calibration: ${err.message}`);
      return;
    }
    const better = (n, o) => (o == null || n == null ? "" : n < o - 0.05 ? "better" : n > o + 0.05 ? "worse" : "");
    review.hidden = false;
    review.replaceChildren(
      el("h3", {}, `Review run ${run.id} before it is used`, cmp.active_id ? el("small", {}, ` (active now: run ${cmp.active_id})`) : el("small", {}, " (no calibration is active yet)")),
      el(
        "table",
        { id: "calibration-compare" },
        el(
          "thead",
          {},
          el("tr", {}, ...["camera", "RMS now (px)", `RMS run ${run.id} (px)`, "markers now", "markers new", "walls new", "moved (cm)", "turned (°)"].map((h) => el("th", {}, h))),
        ),
        el(
          "tbody",
          {},
          ...cmp.cameras.map((c) =>
            el(
              "tr",
              {},
              el("td", {}, c.name),
              el("td", {}, c.active ? px(c.active.rms_px) : "–"),
              el("td", { class: better(c.new.rms_px, c.active && c.active.rms_px) }, `${px(c.new.rms_px)} ${c.new.verdict || ""}`),
              el("td", {}, c.active ? String(c.active.markers_used ?? "–") : "–"),
              el("td", {}, String(c.new.markers_used ?? "–")),
              el("td", {}, (c.new.walls_seen || []).join(", ")),
              el("td", {}, c.moved_m == null ? "–" : (100 * c.moved_m).toFixed(1)),
              el("td", {}, c.turned_deg == null ? "–" : c.turned_deg.toFixed(2)),
            ),
          ),
        ),
      ),
      el(
        "div",
        { class: "row" },
        el("button", { id: "calibration-accept", onclick: () => activate(run.id) }, `Accept run ${run.id}`),
        el("button", { class: "secondary", onclick: () => dismiss() }, cmp.active_id ? `Keep run ${cmp.active_id}` : "Not now"),
      ),
    );
    showOverlays(run); // large, one per column, under the table
  }

  function dismiss() {
    review.hidden = true;
    review.replaceChildren();
  }

  async function refresh() {
    let runs;
    try {
      runs = await get("/calibration/runs");
    } catch (err) {
      toast(`calibration: ${err.message}`);
      return;
    }
    tbody.replaceChildren(
      ...runs.map((r) =>
        el(
          "tr",
          { class: r.active ? "active" : "" },
          el("td", {}, r.id),
          el("td", {}, new Date(r.created_at).toLocaleString()),
          el("td", {}, r.active ? `${r.status} (active)` : r.status === "done" ? "done (not in use)" : r.status),
          el("td", {}, rmsText(r)),
          el(
            "td",
            {},
            r.status === "done" && !r.active ? el("button", { onclick: () => { reviewed = null; showReview(r); } }, "review / accept") : "",
            r.status === "done" ? el("button", { class: "secondary", onclick: () => showOverlays(r) }, "overlays") : "",
          ),
        ),
      ),
    );
    const current = runs[0];
    if (current) {
      progress.value = current.progress;
      message.textContent = `run ${current.id}: ${current.status} — ${current.message}`;
      if (current.status === "pending" || current.status === "running") {
        if (!polling) polling = setInterval(refresh, 500);
      } else if (polling) {
        clearInterval(polling);
        polling = null;
      }
      if (current.status === "done" && !current.active) showReview(current);
    }
  }

  async function activate(id) {
    try {
      await post(`/calibration/runs/${id}/activate`);
      dismiss();
      toast(`calibration run ${id} is accepted: the cameras use it from the pipeline's next start`, "ok");
      await refresh();
    } catch (err) {
      toast(`activate: ${err.message}`);
    }
  }

  document.getElementById("calibration-start").addEventListener("click", async () => {
    try {
      reviewed = null;
      await post("/calibration/runs");
      await refresh();
    } catch (err) {
      toast(`calibration: ${err.message}`);
    }
  });
  refresh();
}
