// The embedded viser 3D view (its own port on the same host).

export function mountViewer(info) {
  const frame = document.getElementById("viewer-frame");
  const link = document.getElementById("viewer-link");
  if (!info.viser_port) {
    frame.replaceWith(document.createTextNode("The 3D view is off in the settings (server.viser)."));
    return;
  }
  const url = `${location.protocol}//${location.hostname}:${info.viser_port}/`;
  frame.src = url;
  link.href = url;
}
