// The live status: WebSocket /api/v1/ws/live (about ten messages a second), reconnecting;
// panels subscribe with onStatus(fn).

import { token } from "./api.js";

const listeners = new Set();
let socket = null;

export function onStatus(fn) {
  listeners.add(fn);
  return () => listeners.delete(fn);
}

function setSocketState(state) {
  const pill = document.getElementById("ws-state");
  pill.dataset.state = state;
  pill.textContent = `live: ${state}`;
}

export function connect() {
  const proto = location.protocol === "https:" ? "wss" : "ws";
  const q = token() ? `?token=${encodeURIComponent(token())}` : "";
  socket = new WebSocket(`${proto}://${location.host}/api/v1/ws/live${q}`);
  socket.onopen = () => setSocketState("open");
  socket.onmessage = (ev) => {
    const status = JSON.parse(ev.data);
    for (const fn of listeners) {
      try {
        fn(status);
      } catch (err) {
        console.error(err);
      }
    }
  };
  socket.onclose = () => {
    setSocketState("closed");
    setTimeout(connect, 1000);
  };
}
