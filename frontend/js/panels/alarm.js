// The alarm banner: raised by the server when no locomotion command has gone out for more than 2 s
// during a running session (status "alarm"); it stays in view until commands flow again.

import { onStatus } from "../live.js";

export function mountAlarm() {
  const box = document.getElementById("alarm");
  onStatus((s) => {
    const a = s.alarm;
    if (!a) {
      box.hidden = true;
      box.dataset.alarm = "";
      return;
    }
    box.hidden = false;
    box.dataset.alarm = a.kind;
    box.replaceChildren(
      document.createTextNode(`No locomotion command for ${Number(a.gap_s).toFixed(1)} s — ${a.reason}`),
      Object.assign(document.createElement("small"), {
        textContent: `session ${a.session_id}: nobody is steering. Pick a person in the People panel, or press "Automatic navigator".`,
      }),
    );
  });
}
