// The people tracked now; a click makes one the navigator (PUT /navigator), or back to automatic.

import { put, toast, el } from "../api.js";
import { onStatus } from "../live.js";

async function choose(body) {
  try {
    await put("/navigator", body);
  } catch (err) {
    toast(`navigator: ${err.message}`);
  }
}

export function mountPeople() {
  const list = document.getElementById("people-list");
  onStatus((s) => {
    document.getElementById("navigator").textContent = s.navigator ?? "none";
    document.getElementById("navigator-mode").textContent = s.navigator_mode;
    const people = s.people || [];
    const key = JSON.stringify(people.map((p) => [p.user_id, p.is_navigator]));
    if (list.dataset.key !== key) {
      list.dataset.key = key;
      list.replaceChildren(
        ...people.map((p) =>
          el(
            "li",
            {},
            el(
              "button",
              {
                class: `person${p.is_navigator ? " navigator" : ""}`,
                dataset: { userId: p.user_id },
                title: "make this person the navigator",
                onclick: () => choose({ user_id: p.user_id }),
              },
              `user ${p.user_id}`,
              el("small", { class: "pos" }, ""),
            ),
          ),
        ),
      );
    }
    people.forEach((p, i) => {
      const pos = list.children[i]?.querySelector(".pos");
      if (pos) pos.textContent = p.position_m ? ` (${p.position_m[0].toFixed(2)}, ${p.position_m[1].toFixed(2)}) m` : "";
    });
  });
  document.getElementById("navigator-auto").addEventListener("click", () => choose({ mode: "auto" }));
}
