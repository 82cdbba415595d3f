// The embedded viser 3D view, proxied by the app at /viewer/ (behind the operator token: the page's
// ?token= sets a cookie scoped to /viewer that lets the view's own WebSocket in).

import { withToken } from "../api.js";

export function mountViewer(info) {
  const frame = document.getElementById("viewer-frame");
  const link = document.getElementById("viewer-link");
  if (!info.viewer_url) {
    frame.replaceWith(document.createTextNode("The 3D view is off in the settings (server.viser)."));
    return;
  }
  const url = withToken(info.viewer_url);
  frame.src = url;
  link.href = url;
}
