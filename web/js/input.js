// Mouse, pen and touch on the viewer's canvas through pointer events: drag to orbit, shift- or right-drag (or two
// fingers) to pan, wheel or pinch to zoom. It only reports gestures; the page decides what they do to the view.

const ORBIT_DEG_PER_PIXEL = 0.4;

/// Attaches the gestures to `element`. `handlers`: begin() when a drag starts, orbit(dAz, dEl), pan(dxPixels,
/// dyPixels), zoom(factor) (below 1 moves closer), end() when the last pointer is released.
export function attachGestures(element, handlers) {
  const pointers = new Map(); // pointerId -> {x, y}
  let mode = null; // "orbit" | "pan" | "pinch"
  let pinch = null; // {distance, mid} of the two pointers at the last move

  const twoPointers = () => {
    const [a, b] = [...pointers.values()];
    return { distance: Math.hypot(a.x - b.x, a.y - b.y), mid: { x: (a.x + b.x) / 2, y: (a.y + b.y) / 2 } };
  };

  element.addEventListener("contextmenu", (e) => e.preventDefault());
  element.addEventListener("pointerdown", (e) => {
    element.setPointerCapture(e.pointerId);
    pointers.set(e.pointerId, { x: e.clientX, y: e.clientY });
    if (pointers.size === 1) {
      mode = e.shiftKey || e.button === 2 || e.button === 1 ? "pan" : "orbit";
      handlers.begin();
    } else if (pointers.size === 2) {
      mode = "pinch";
      pinch = twoPointers();
    }
    e.preventDefault();
  });
  element.addEventListener("pointermove", (e) => {
    const p = pointers.get(e.pointerId);
    if (!p) return;
    const [dx, dy] = [e.clientX - p.x, e.clientY - p.y];
    pointers.set(e.pointerId, { x: e.clientX, y: e.clientY });
    if (mode === "orbit") handlers.orbit(-dx * ORBIT_DEG_PER_PIXEL, dy * ORBIT_DEG_PER_PIXEL);
    else if (mode === "pan") handlers.pan(dx, dy);
    else if (mode === "pinch" && pointers.size === 2) {
      const now = twoPointers();
      if (pinch.distance > 0 && now.distance > 0) handlers.zoom(pinch.distance / now.distance);
      handlers.pan(now.mid.x - pinch.mid.x, now.mid.y - pinch.mid.y);
      pinch = now;
    }
  });
  const release = (e) => {
    if (!pointers.delete(e.pointerId)) return;
    if (pointers.size === 1 && mode === "pinch") mode = "pan"; // one finger left: it pans until lifted
    if (pointers.size === 0) {
      mode = null;
      handlers.end();
    }
  };
  element.addEventListener("pointerup", release);
  element.addEventListener("pointercancel", release);
  element.addEventListener(
    "wheel",
    (e) => {
      e.preventDefault();
      const lines = e.deltaMode === 1 ? 40 : e.deltaMode === 2 ? 400 : 1;
      handlers.zoom(Math.exp(Math.max(-100, Math.min(100, e.deltaY * lines)) * 0.002));
      handlers.wheel();
    },
    { passive: false },
  );
}
