// procgen gallery pages: frame players, 3-D views loaded on demand, and a load check.
"use strict";

// A frame strip: clicking a frame shows it large; "play" steps through the series.
for (const player of document.querySelectorAll(".player")) {
  const big = player.querySelector("img.big");
  const frames = Array.from(player.querySelectorAll(".strip img"));
  const button = player.querySelector("button");
  let at = frames.length - 1, timer = null;
  const show = (i) => { at = i; big.src = frames[i].dataset.full; big.alt = frames[i].alt; };
  frames.forEach((f, i) => f.addEventListener("click", () => show(i)));
  button.addEventListener("click", () => {
    if (timer) { clearInterval(timer); timer = null; button.textContent = "play"; return; }
    button.textContent = "pause";
    timer = setInterval(() => show((at + 1) % frames.length), 400);
  });
}

// 3-D views: the viewer and the model load when asked, so a page with six meshes stays light.
// Over http(s) the viewer reads the GLB itself; from a file:// page a browser may not read a
// neighbouring file, so the model comes from a script copy of it (data.js) the gallery wrote.
window.procgenModels = window.procgenModels || {};
function loadScript(src) {
  return new Promise((ok, fail) => {
    const s = document.createElement("script");
    s.src = src; s.onload = ok; s.onerror = () => fail(new Error("cannot load " + src));
    document.head.appendChild(s);
  });
}
async function modelURL(view) {
  if (location.protocol !== "file:" || !view.dataset.js) return view.dataset.glb;
  await loadScript(view.dataset.js);
  const b64 = window.procgenModels[view.dataset.glb];
  const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
  return URL.createObjectURL(new Blob([bytes], { type: "model/gltf-binary" }));
}
for (const view of document.querySelectorAll(".view3d")) {
  const button = view.querySelector("button");
  if (!button) continue;
  button.addEventListener("click", async () => {
    button.disabled = true; button.textContent = "loading...";
    try {
      if (!customElements.get("model-viewer")) await loadScript(view.dataset.viewer);
      const mv = document.createElement("model-viewer");
      mv.setAttribute("camera-controls", ""); mv.setAttribute("shadow-intensity", "0.6");
      mv.setAttribute("exposure", "1.0"); mv.setAttribute("alt", view.dataset.glb);
      mv.addEventListener("load", () => { view.dataset.loaded = "1"; });
      mv.addEventListener("error", () => { view.dataset.failed = "1"; });
      mv.src = await modelURL(view);
      button.replaceWith(mv);
    } catch (e) {
      view.dataset.failed = "1"; button.textContent = String(e);
    }
  });
}

// lets a headless browser (and a curious reader) check that every picture decoded
window.addEventListener("load", () => {
  const imgs = Array.from(document.images).filter((i) => i.loading !== "lazy" || i.complete);
  document.body.dataset.images = document.images.length;
  document.body.dataset.broken = imgs.filter((i) => !(i.complete && i.naturalWidth > 0)).length;
});
