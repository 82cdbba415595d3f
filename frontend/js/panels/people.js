// The people tracked now; a click makes one the navigator (PUT /navigator), or back to automatic.
// The navigation mode (issue 20): single, each (everyone ticked, or everyone, has their own
// stream) or group (one command for the room); each person's row shows their own command, its
// confidence, and a strip of their command and feet over the last seconds.
//
// The list is updated in place, one row per user id, in id order: a person who stays tracked
// keeps the same button however often the status arrives and whatever order the tracker lists
// people in. (Rebuilding the list whenever the order or the navigator changed detached the
// button under the operator's pointer, so that a click on a busy machine could miss: issue 15 S3.)

import { put, toast, el } from "../api.js";
import { onStatus } from "../live.js";
import { footTick } from "./steps.js";

const STRIP = 60; // ticks per person: about six seconds at ten updates a second

async function choose(body) {
  try {
    await put("/navigator", body);
  } catch (err) {
    toast(`navigator: ${err.message}`);
  }
}

function push(strip, tick) {
  strip.append(tick);
  while (strip.childElementCount > STRIP) strip.firstElementChild.remove();
}

function personRow(userId) {
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
    el(
      "div",
      { class: "person-line" },
      el("input", { type: "checkbox", class: "chosen", title: "one of the chosen people (each / group mode)",
        "aria-label": `choose user ${userId}` }),
      el("span", { class: "person-command none" }, "no command"),
    ),
    el("div", { class: "history person-strip commands", title: "this person's command, newest on the right" }),
    el("div", { class: "history person-strip feet", title: "this person's feet: planted / swinging" }),
  );
}

function chosenIds(list) {
  return [...list.querySelectorAll("li")]
    .filter((li) => li.querySelector(".chosen").checked)
    .map((li) => Number(li.dataset.userId));
}

// The operator's ticks, by user id: a person the tracker loses for a moment gets a new row when
// they are back, and that row must keep its tick (else group mode quietly drops them).
const ticked = new Set();
// A row stays (greyed) this long after its person drops out of the status: the tracker misses
// someone for a frame or two, and the row, its strip and its tick must not flicker away. The
// server counts them as tracked as long (pipeline.navigation.config.TRACKED_WITHIN_S).
const LOST_GRACE_MS = 1000;

function showPerson(row, p) {
  const button = row.firstElementChild;
  button.classList.toggle("navigator", Boolean(p.is_navigator));
  const pos = button.querySelector(".pos");
  const text = p.position_m ? ` (${p.position_m[0].toFixed(2)}, ${p.position_m[1].toFixed(2)}) m` : "";
  if (pos.textContent !== text) pos.textContent = text;
  const c = p.command;
  const badge = row.querySelector(".person-command");
  badge.className = `person-command ${c ? c.label : "none"}`;
  badge.textContent = c ? `${c.label} ${(100 * c.confidence).toFixed(0)} %` : "no command";
  row.dataset.command = c ? c.label : "";
  push(row.querySelector(".commands"), el("span", { class: `tick ${c ? c.label : "none"}` }));
  const feet = c && c.steps && c.steps.feet;
  const moving = feet ? feet.find((f) => f && f.known && !f.planted) || feet[0] : null;
  push(row.querySelector(".feet"), moving ? footTick(moving) : el("span", { class: "tick none" }));
}

export function mountPeople() {
  const list = document.getElementById("people-list");
  const modes = document.getElementById("navigation-modes");
  const groupText = document.getElementById("navigation-group");
  const missingText = document.getElementById("navigation-missing");
  const rows = new Map(); // user id -> its <li>, kept while the person is tracked
  const seen = new Map(); // user id -> Date.now() of the last status that had them
  onStatus((s) => {
    document.getElementById("navigator").textContent = s.navigator ?? "none";
    document.getElementById("navigator-mode").textContent = s.navigator_mode;
    const nav = s.navigation || { mode: "single", chosen: [], group: null };
    for (const b of modes.querySelectorAll(".mode")) b.classList.toggle("active", b.dataset.mode === nav.mode);
    modes.dataset.mode = nav.mode;
    const g = nav.group;
    groupText.textContent = nav.mode !== "group" ? "" : g
      ? `room: ${g.label} ${(100 * g.confidence).toFixed(0)} % (votes ${Object.entries(g.votes)
        .filter(([, n]) => n).map(([k, n]) => `${k} ${n}`).join(", ")})`
      : "room: nobody tracked";
    const people = s.people || [];
    const now = new Set(people.map((p) => p.user_id));
    const t = Date.now();
    for (const id of now) seen.set(id, t);
    // chosen people nobody has now (gone, or numbered afresh by a new run): they get no command
    const chosenNow = nav.mode === "single" ? [] : nav.chosen || [];
    const missing = chosenNow.filter((id) => t - (seen.get(id) ?? 0) > LOST_GRACE_MS);
    missingText.hidden = !missing.length;
    missingText.textContent = !missing.length ? "" : `Chosen but not tracked now: ${missing.join(", ")}`
      + (missing.length === chosenNow.length ? " (nobody navigates)" : "")
      + ". Tick the people and choose the mode again.";
    for (const [id, row] of rows) {
      const lost = !now.has(id);
      row.classList.toggle("lost", lost);
      if (lost && t - (seen.get(id) ?? 0) > LOST_GRACE_MS) {
        row.remove();
        rows.delete(id);
        seen.delete(id);
      }
    }
    // by user id, the rows of people lost a moment ago included (they keep their place)
    const byId = new Map(people.map((p) => [p.user_id, p]));
    const ids = [...new Set([...rows.keys(), ...byId.keys()])].sort((x, y) => x - y);
    let before = list.firstElementChild;
    for (const id of ids) {
      const p = byId.get(id);
      let row = rows.get(id);
      if (!row) {
        row = personRow(id);
        const box = row.querySelector(".chosen");
        box.checked = ticked.has(id) || (nav.chosen || []).includes(id);
        if (box.checked) ticked.add(id);
        box.addEventListener("change", () => (box.checked ? ticked.add(id) : ticked.delete(id)));
        rows.set(id, row);
      }
      if (row !== before) list.insertBefore(row, before); // new, or out of place: nothing else moves
      else before = before.nextElementSibling;
      if (p) showPerson(row, p);
    }
  });
  for (const b of modes.querySelectorAll(".mode")) {
    b.addEventListener("click", () => {
      const mode = b.dataset.mode;
      choose(mode === "single" ? { mode: "single" } : { mode, user_ids: chosenIds(list) });
    });
  }
  document.getElementById("navigator-auto").addEventListener("click", () => choose({ mode: "auto" }));
}
