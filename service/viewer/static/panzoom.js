// The map pages' pan and zoom (the plan's page and the fleet's), and their scale bar.
"use strict";

// The board, drawn at its own pixels (w x h), scaled to fill the window less `below` pixels
// under it, zoomed about the pointer with the wheel (1 to 40 times) and panned with a drag;
// `onScale(s)` redraws what depends on the scale (the scale bar, labels). Returns `fit`, to
// call again when the page's layout changes (it answers the scale that fills the window).
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

// A scale bar in the svg `bar`: a round length drawn 80 to 200 screen pixels long at
// `perMeter` screen pixels a meter, and its meters written beside it.
function scaleBar(bar, perMeter) {
  const NS = "http://www.w3.org/2000/svg";
  bar.replaceChildren();
  const lengths = [0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 50, 100, 200, 500, 1000];
  const meters = lengths.find((m) => m * perMeter >= 80) || lengths[lengths.length - 1];
  const len = meters * perMeter;
  for (const [x1, y1, x2, y2] of [[1, 18, 1 + len, 18], [1, 13, 1, 21], [1 + len, 13, 1 + len, 21]]) {
    const line = document.createElementNS(NS, "line");
    line.setAttribute("x1", x1); line.setAttribute("y1", y1);
    line.setAttribute("x2", x2); line.setAttribute("y2", y2);
    bar.appendChild(line);
  }
  const label = document.createElementNS(NS, "text");
  label.setAttribute("x", len + 8); label.setAttribute("y", 21);
  label.textContent = meters + " m";
  bar.appendChild(label);
  bar.setAttribute("width", len + 70);
  bar.dataset.meters = String(meters);
  bar.dataset.pixels = String(len);
}
