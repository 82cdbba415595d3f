// The live status: WebSocket /api/v1/ws/live (about ten messages a second), reconnecting with back-off;
// panels subscribe with onStatus(fn).

import { token } from "./api.js";

const listeners = new Set();
let socket = null;
const RETRY_MIN_MS = 500;
const RETRY_MAX_MS = 10000;
let retryMs = RETRY_MIN_MS;

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
  socket.onopen = () => {
    retryMs = RETRY_MIN_MS; // a connection that opened starts its back-off afresh
    setSocketState("open");
  };
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
    // back off (0.5 s doubling to 10 s, with jitter) so that a server that is down or
    // restarting is not hammered by every open dashboard at once
    const delay = retryMs * (0.75 + Math.random() * 0.5);
    retryMs = Math.min(RETRY_MAX_MS, retryMs * 2);
    setTimeout(connect, delay);
  };
}
