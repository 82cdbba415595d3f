// Camera coverage: plan the active calibration, the default layout, a proposed set (calibration JSON)
// or a mount search for N cameras; show the floor heat maps, the numbers by region, the best layouts,
// and a per-joint map drawn from the plan's numbers.

import { get, post, toast, el, withToken } from "../api.js";

const REGIONS = ["centre", "inner", "edges", "corners"];

function num(x, digits = 1) {
  return x === null || x === undefined ? "–" : Number(x).toFixed(digits);
}

function pct(x) {
  return x === null || x === undefined ? "–" : `${(100 * x).toFixed(0)} %`;
}

// A floor map from the plan's numbers: rows of cells (y ascending), drawn with +y up.
function drawMap(canvas, values, vmax, label) {
  const ctx = canvas.getContext("2d");
  const ny = values.length;
  const nx = ny ? values[0].length : 0;
  const w = canvas.width;
  const h = canvas.height;
  ctx.clearRect(0, 0, w, h);
  if (!nx) return;
  const cell = Math.min((w - 20) / nx, (h - 30) / ny);
  for (let iy = 0; iy < ny; iy += 1) {
    for (let ix = 0; ix < nx; ix += 1) {
      const v = values[iy][ix];
      if (v === null) continue;
      const t = Math.max(0, Math.min(1, v / vmax));
      // light yellow (0) -> dark purple (vmax)
      const r = Math.round(252 - 200 * t);
      const g = Math.round(236 - 220 * t);
      const b = Math.round(180 - 80 * t);
      ctx.fillStyle = `rgb(${r},${g},${b})`;
      ctx.fillRect(10 + ix * cell, 10 + (ny - 1 - iy) * cell, cell, cell);
    }
  }
  ctx.strokeStyle = "#111";
  ctx.strokeRect(10, 10, nx * cell, ny * cell);
  ctx.fillStyle = "#111";
  ctx.font = "12px sans-serif";
  ctx.fillText(`${label} (0 – ${num(vmax, 1)}); front wall at the top`, 10, 10 + ny * cell + 16);
}

export function mountPlanner(root) {
  const source = el(
    "select",
    { id: "planner-source", "aria-label": "cameras to plan" },
    el("option", { value: "active" }, "active calibration"),
    el("option", { value: "default" }, "default layout"),
    el("option", { value: "proposed" }, "proposed set (calibration JSON)"),
    el("option", { value: "search" }, "find mounts for N cameras"),
  );
  const count = el("input", { id: "planner-count", type: "number", min: "2", max: "16", value: "4", "aria-label": "cameras" });
  const file = el("input", { id: "planner-file", type: "file", accept: ".json,application/json", "aria-label": "proposed cameras" });
  const grid = el(
    "select",
    { id: "planner-grid", "aria-label": "floor cell size" },
    el("option", { value: "0.3" }, "quick (0.3 m cells)"),
    el("option", { value: "0.15" }, "fine (0.15 m cells)"),
  );
  const start = el("button", { id: "planner-start", type: "button" }, "Plan");
  const progress = el("progress", { id: "planner-progress", max: "1", value: "0" });
  const message = el("span", { id: "planner-message" });
  const summary = el("p", { id: "planner-summary" });
  const regions = el("table", { id: "planner-regions" });
  const layouts = el("table", { id: "planner-layouts" });
  const figures = el("div", { id: "planner-figures", style: "display: grid; gap: 0.6rem;" });
  const joint = el("select", { id: "planner-joint", "aria-label": "joint" });
  const quantity = el(
    "select",
    { id: "planner-quantity", "aria-label": "map" },
    el("option", { value: "views" }, "cameras seeing the joint"),
    el("option", { value: "error" }, "expected error (mm)"),
  );
  const canvas = el("canvas", { id: "planner-canvas", width: "420", height: "440" });
  const jointRow = el("div", { class: "row", hidden: "" }, "per joint: ", joint, quantity);

  const showCount = () => {
    count.hidden = source.value !== "search";
    file.hidden = source.value !== "proposed";
  };
  source.addEventListener("change", showCount);
  showCount();

  root.replaceChildren(
    el("div", { class: "row" }, source, count, file, grid, start, progress, message),
    summary,
    regions,
    layouts,
    jointRow,
    canvas,
    figures,
  );

  let current = null; // the map shown per joint: { grid, maps, cameras }

  function drawJoint() {
    if (!current) return;
    const j = Number(joint.value);
    if (quantity.value === "views") {
      drawMap(canvas, current.maps.views_joint[j], current.cameras, `cameras seeing ${current.joints[j]}`);
    } else {
      const vals = current.maps.error_joint_mm[j];
      const finite = vals.flat().filter((v) => v !== null);
      const vmax = finite.length ? Math.max(5, ...finite) : 10;
      drawMap(canvas, vals, vmax, `expected error of ${current.joints[j]} (mm)`);
    }
  }
  joint.addEventListener("change", drawJoint);
  quantity.addEventListener("change", drawJoint);

  function show(job) {
    const r = job.result;
    const s = r.summary;
    summary.textContent = `${r.source}: floor mean ${num(s.mean_error_mm)} mm, worst region ${s.worst_region}, ` +
      `${pct(s.covered2)} of joints seen by ≥ 2 cameras, ${pct(s.valid)} triangulated; ` +
      `map ${num(s.map_seconds, 2)} s, plan ${num(r.elapsed_s, 1)} s`;
    regions.replaceChildren(
      el("thead", {}, el("tr", {}, ...["region", "cells", "error (mm)", "valid", "cameras per joint", "≥ 2 cameras"].map((h) => el("th", {}, h)))),
      el(
        "tbody",
        {},
        ...REGIONS.filter((k) => s.regions[k]).map((k) => {
          const g = s.regions[k];
          return el("tr", { dataset: { region: k } }, el("td", {}, k), el("td", {}, g.cells), el("td", {}, num(g.error_mm)),
            el("td", {}, pct(g.valid)), el("td", {}, num(g.views, 2)), el("td", {}, pct(g.covered2)));
        }),
      ),
    );
    if (r.search) {
      const rows = [...r.search.layouts, ...(r.search.default ? [r.search.default] : [])];
      layouts.replaceChildren(
        el("thead", {}, el("tr", {}, ...["layout", "objective", "mean (mm)", "centre", "corners", "≥ 2 cameras", "mounts"].map((h) => el("th", {}, h)))),
        el(
          "tbody",
          {},
          ...rows.map((l) => el("tr", { dataset: { layout: l.name } }, el("td", {}, l.name), el("td", {}, num(l.objective_mm)),
            el("td", {}, num(l.mean_error_mm)), el("td", {}, num(l.centre_error_mm)), el("td", {}, num(l.corner_error_mm)),
            el("td", {}, pct(l.covered2)),
            el("td", {}, (l.mounts || []).map((m) => m.label).join("; ") || "(given cameras)"))),
        ),
      );
    } else {
      layouts.replaceChildren();
    }
    const map = r.coverage || (r.search && r.search.layouts[0].map);
    current = { maps: map.maps, cameras: map.cameras.length, joints: map.joints };
    joint.replaceChildren(...map.joints.map((name, i) => el("option", { value: String(i) }, name)));
    joint.value = String(map.joints.indexOf("l_ankle"));
    jointRow.hidden = false;
    drawJoint();
    figures.replaceChildren(
      ...job.figures.filter((u) => u.endsWith(".png")).map((u) =>
        el("figure", { style: "margin: 0;" },
          el("a", { href: withToken(u.replace(/\.png$/, ".svg")), target: "_blank" },
            el("img", { src: withToken(u), alt: u.split("/").pop(), style: "max-width: 100%; height: auto;" })),
          el("figcaption", {}, u.split("/").pop().replace(".png", " (click for SVG)"))),
      ),
    );
  }

  async function follow(id) {
    for (;;) {
      let job;
      try {
        job = await get(`/plan/${id}`);
      } catch (err) {
        toast(`plan: ${err.message}`);
        return;
      }
      progress.value = job.progress;
      message.textContent = `plan ${job.id}: ${job.status} — ${job.message}`;
      if (job.status === "done") {
        show(job);
        return;
      }
      if (job.status === "failed") {
        toast(`plan: ${job.message}`);
        return;
      }
      await new Promise((resolve) => setTimeout(resolve, 400));
    }
  }

  start.addEventListener("click", async () => {
    const body = { source: source.value, grid_step_m: Number(grid.value) };
    if (source.value === "search") body.count = Number(count.value);
    if (source.value === "proposed") {
      if (!file.files.length) {
        toast("plan: choose a calibration JSON of the proposed cameras");
        return;
      }
      try {
        body.calibration = JSON.parse(await file.files[0].text());
      } catch (err) {
        toast(`plan: the file is not JSON (${err.message})`);
        return;
      }
    }
    start.disabled = true;
    message.textContent = "starting…";
    progress.value = 0;
    try {
      const job = await post("/plan", body);
      await follow(job.id);
    } catch (err) {
      toast(`plan: ${err.message}`);
      message.textContent = `refused: ${err.message}`;
    } finally {
      start.disabled = false;
    }
  });
}
