// The people tracked now; a click makes one the navigator (PUT /navigator), or back to automatic.
//
// The list is updated in place, one button per user id, in id order: a person who stays tracked
// keeps the same button however often the status arrives and whatever order the tracker lists
// people in. (Rebuilding the list whenever the order or the navigator changed detached the
// button under the operator's pointer, so that a click on a busy machine could miss: issue 15 S3.)

import { put, toast, el } from "../api.js";
import { onStatus } from "../live.js";

async function choose(body) {
  try {
    await put("/navigator", body);
  } catch (err) {
    toast(`navigator: ${err.message}`);
  }
}

function personButton(userId) {
  return el(
    "li",
    { dataset: { userId } },
    el(
      "button",
      {
        class: "person",
        dataset: { userId },
        title: "make this person the navigator",
        onclick: () => choose({ user_id: userId }),
      },
      `user ${userId}`,
      el("small", { class: "pos" }, ""),
    ),
  );
}

export function mountPeople() {
  const list = document.getElementById("people-list");
  const rows = new Map(); // user id -> its <li>, kept while the person is tracked
  onStatus((s) => {
    document.getElementById("navigator").textContent = s.navigator ?? "none";
    document.getElementById("navigator-mode").textContent = s.navigator_mode;
    const people = [...(s.people || [])].sort((a, b) => a.user_id - b.user_id);
    const now = new Set(people.map((p) => p.user_id));
    for (const [id, row] of rows) {
      if (!now.has(id)) {
        row.remove();
        rows.delete(id);
      }
    }
    let before = list.firstElementChild;
    for (const p of people) {
      let row = rows.get(p.user_id);
      if (!row) {
        row = personButton(p.user_id);
        rows.set(p.user_id, row);
      }
      if (row !== before) list.insertBefore(row, before); // new, or out of place: nothing else moves
      else before = before.nextElementSibling;
      const button = row.firstElementChild;
      button.classList.toggle("navigator", Boolean(p.is_navigator));
      const pos = button.querySelector(".pos");
      const text = p.position_m ? ` (${p.position_m[0].toFixed(2)}, ${p.position_m[1].toFixed(2)}) m` : "";
      if (pos.textContent !== text) pos.textContent = text;
    }
  });
  document.getElementById("navigator-auto").addEventListener("click", () => choose({ mode: "auto" }));
}
