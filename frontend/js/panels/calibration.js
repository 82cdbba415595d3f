// Calibration: start a run, follow its progress, RMS per camera, overlays, accept / roll back.

import { get, post, toast, el, withToken } from "../api.js";

function rmsText(run) {
  return run.cameras.map((c) => `${c.name} ${c.rms_px == null ? "–" : c.rms_px.toFixed(2)} (${c.verdict || "?"})`).join(", ");
}

export function mountCalibration(info) {
  const progress = document.getElementById("calibration-progress");
  const message = document.getElementById("calibration-message");
  const tbody = document.querySelector("#calibration-runs tbody");
  const overlays = document.getElementById("calibration-overlays");
  let polling = null;

  document.getElementById("calibration-patterns").replaceChildren(
    el("span", {}, "wall patterns: "),
    ...info.walls.map((w) =>
      el("a", { href: withToken(`/api/v1/calibration/patterns/${w}.png`), target: "_blank" }, w),
    ),
  );

  function showOverlays(run) {
    overlays.replaceChildren(
      ...run.cameras.map((c) =>
        el(
          "figure",
          { class: "overlay" },
          el("img", { src: withToken(`/api/v1/calibration/runs/${run.id}/overlays/${c.name}.png`), alt: c.name }),
          el("figcaption", {}, `${c.name}: ${c.rms_px == null ? "–" : c.rms_px.toFixed(2)} px, ${c.verdict || ""}`),
        ),
      ),
    );
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
          el("td", {}, r.active ? `${r.status} (active)` : r.status),
          el("td", {}, rmsText(r)),
          el(
            "td",
            {},
            r.status === "done" && !r.active
              ? el("button", { onclick: () => activate(r.id) }, "make active")
              : "",
            r.status === "done" ? el("button", { onclick: () => showOverlays(r) }, "overlays") : "",
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
        if (current.status === "done") showOverlays(current);
      }
    }
  }

  async function activate(id) {
    try {
      await post(`/calibration/runs/${id}/activate`);
      await refresh();
    } catch (err) {
      toast(`activate: ${err.message}`);
    }
  }

  document.getElementById("calibration-start").addEventListener("click", async () => {
    try {
      await post("/calibration/runs");
      await refresh();
    } catch (err) {
      toast(`calibration: ${err.message}`);
    }
  });
  refresh();
}
