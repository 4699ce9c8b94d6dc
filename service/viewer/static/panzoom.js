// The map pages' pan and zoom (the plan's page and the fleet's): the board, drawn at its own
// pixels (w x h), scaled to fill the window less `below` pixels under it, zoomed about the
// pointer with the wheel (1 to 40 times) and panned with a drag; `onScale(s)` redraws what
// depends on the scale (the scale bar, labels). Returns `fit`, to call again when the page's
// layout changes (it answers the scale that fills the window).
"use strict";
function panZoom(frame, board, w, h, below, onScale) {
  const view = { zoom: 1, x: 0, y: 0, fit: 1 };
  function show() {
    const s = view.fit * view.zoom;
    board.style.transform = "translate(" + view.x + "px," + view.y + "px) scale(" + s + ")";
    board.dataset.scale = String(s);
    frame.dataset.zoom = String(view.zoom);
    onScale(s);
  }
  function fit() {
    const room = document.documentElement.clientWidth - 2 * frame.offsetLeft;
    const height = window.innerHeight - frame.getBoundingClientRect().top - below;
    view.fit = Math.max(0.05, Math.min(room / w, height / h));
    frame.style.width = w * view.fit + "px";
    frame.style.height = h * view.fit + "px";
    show();
    return view.fit;
  }
  frame.addEventListener("wheel", (event) => {
    event.preventDefault();
    const r = frame.getBoundingClientRect();
    const px = event.clientX - r.left, py = event.clientY - r.top;
    const before = view.zoom;
    view.zoom = Math.min(40, Math.max(1, view.zoom * (event.deltaY < 0 ? 1.25 : 0.8)));
    view.x = px - (px - view.x) * view.zoom / before;
    view.y = py - (py - view.y) * view.zoom / before;
    if (view.zoom === 1) view.x = view.y = 0;
    show();
  }, { passive: false });
  let drag = null;
  frame.addEventListener("pointerdown", (e) => { drag = [e.clientX - view.x, e.clientY - view.y]; });
  window.addEventListener("pointerup", () => { drag = null; });
  window.addEventListener("pointermove", (e) => {
    if (drag && view.zoom > 1) { view.x = e.clientX - drag[0]; view.y = e.clientY - drag[1]; show(); }
  });
  window.addEventListener("resize", fit);
  return fit;
}
