// The camera views: low-rate JPEG snapshots with the skeleton overlays drawn by the pipeline.

import { el, withToken } from "../api.js";
import { onStatus } from "../live.js";

const PERIOD_MS = 500;

export function mountCameras(info) {
  const box = document.getElementById("camera-views");
  const views = new Map();
  let names = [];
  function ensure(list) {
    if (JSON.stringify(list) === JSON.stringify(names)) return;
    names = list;
    views.clear();
    box.replaceChildren(
      ...names.map((name) => {
        const img = el("img", { alt: `camera ${name}`, "data-camera": name });
        const fig = el("figure", { class: "camera" }, img, el("figcaption", {}, name));
        img.addEventListener("error", () => fig.classList.add("no-image"));
        img.addEventListener("load", () => fig.classList.remove("no-image"));
        views.set(name, img);
        return fig;
      }),
    );
  }
  ensure(info.cameras);
  onStatus((s) => {
    if (s.cameras && s.cameras.length) ensure(s.cameras.map((c) => c.name));
  });
  setInterval(() => {
    if (document.hidden) return;
    for (const [name, img] of views) {
      img.src = withToken(`/api/v1/cameras/${encodeURIComponent(name)}/snapshot.jpg?t=${Date.now()}`);
    }
  }, PERIOD_MS);
}
