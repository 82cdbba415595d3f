// The alarm banner: raised by the server when no locomotion command has gone out for more than 2 s
// during a running session (status "alarm"); it stays in view until commands flow again. A second
// banner says when the disk is nearly full (status "storage").

import { onStatus } from "../live.js";

export function mountAlarm() {
  const box = document.getElementById("alarm");
  const disk = document.getElementById("storage-alarm");
  onStatus((s) => {
    // the disk is nearly full: the take being recorded has stopped, new takes and backups wait
    const full = s.storage && s.storage.level === "full";
    disk.hidden = !full;
    disk.textContent = full ? `Disk nearly full — ${s.storage.message}` : "";
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
