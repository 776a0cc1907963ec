// A small opacity-curve editor for an inline transfer function ({"points": [[x, r, g, b, a], ...]}): drag a point
// (x between its neighbours, opacity up and down), double-click empty space to add a point, double-click a point to
// remove it (the two ends stay). The colour of each point is kept; a new point takes the colour between its
// neighbours.

const RADIUS = 5;

export class CurveEditor {
  /// `canvas`: the element to draw in; `onChange(points, done)`: called while dragging (done false) and once a
  /// change is finished (done true).
  constructor(canvas, onChange) {
    this.canvas = canvas;
    this.onChange = onChange;
    this.points = [];
    this.active = false; // drawn dim while the transfer function is a preset
    this.dragging = -1;
    canvas.addEventListener("pointerdown", (e) => this.down(e));
    canvas.addEventListener("pointermove", (e) => this.move(e));
    canvas.addEventListener("pointerup", () => this.up());
    canvas.addEventListener("pointercancel", () => this.up());
    canvas.addEventListener("dblclick", (e) => this.toggle(e));
  }

  set(points, active) {
    this.points = points.map((p) => p.slice());
    this.active = active;
    this.draw();
  }

  toCanvas(p) {
    const { width: w, height: h } = this.canvas;
    return [RADIUS + p[0] * (w - 2 * RADIUS), h - RADIUS - p[4] * (h - 2 * RADIUS)];
  }

  fromEvent(e) {
    const r = this.canvas.getBoundingClientRect();
    const { width: w, height: h } = this.canvas;
    const x = ((e.clientX - r.left) * (w / r.width) - RADIUS) / (w - 2 * RADIUS);
    const a = (h - RADIUS - (e.clientY - r.top) * (h / r.height)) / (h - 2 * RADIUS);
    return [Math.min(1, Math.max(0, x)), Math.min(1, Math.max(0, a))];
  }

  hit(e) {
    const r = this.canvas.getBoundingClientRect();
    const [ex, ey] = [
      (e.clientX - r.left) * (this.canvas.width / r.width),
      (e.clientY - r.top) * (this.canvas.height / r.height),
    ];
    return this.points.findIndex((p) => {
      const [x, y] = this.toCanvas(p);
      return Math.hypot(x - ex, y - ey) <= RADIUS + 3;
    });
  }

  down(e) {
    this.dragging = this.hit(e);
    if (this.dragging >= 0) this.canvas.setPointerCapture(e.pointerId);
  }

  move(e) {
    if (this.dragging < 0) return;
    const i = this.dragging;
    const [x, a] = this.fromEvent(e);
    const lo = i === 0 ? 0 : this.points[i - 1][0];
    const hi = i === this.points.length - 1 ? 1 : this.points[i + 1][0];
    this.points[i][0] = Number(Math.min(hi, Math.max(lo, x)).toFixed(3));
    this.points[i][4] = Number(a.toFixed(3));
    this.changed(false);
  }

  up() {
    if (this.dragging < 0) return;
    this.dragging = -1;
    this.changed(true);
  }

  toggle(e) {
    const i = this.hit(e);
    if (i > 0 && i < this.points.length - 1) {
      this.points.splice(i, 1);
    } else if (i < 0) {
      const [x, a] = this.fromEvent(e);
      const after = this.points.findIndex((p) => p[0] > x);
      const at = after < 0 ? this.points.length : after;
      const [p0, p1] = [this.points[Math.max(0, at - 1)], this.points[Math.min(this.points.length - 1, at)]];
      const t = p1[0] > p0[0] ? (x - p0[0]) / (p1[0] - p0[0]) : 0;
      const colour = [1, 2, 3].map((c) => Number((p0[c] + t * (p1[c] - p0[c])).toFixed(3)));
      this.points.splice(at, 0, [Number(x.toFixed(3)), ...colour, Number(a.toFixed(3))]);
    } else {
      return;
    }
    this.changed(true);
  }

  changed(done) {
    this.active = true;
    this.draw();
    this.onChange(
      this.points.map((p) => p.slice()),
      done,
    );
  }

  draw() {
    const ctx = this.canvas.getContext("2d");
    const { width: w, height: h } = this.canvas;
    ctx.clearRect(0, 0, w, h);
    const grad = ctx.createLinearGradient(RADIUS, 0, w - RADIUS, 0);
    for (const p of this.points) grad.addColorStop(p[0], `rgb(${p[1] * 255},${p[2] * 255},${p[3] * 255})`);
    ctx.globalAlpha = this.active ? 0.35 : 0.15;
    ctx.fillStyle = grad;
    ctx.fillRect(RADIUS, h - RADIUS - 6, w - 2 * RADIUS, 6);
    ctx.globalAlpha = this.active ? 1 : 0.4;
    ctx.strokeStyle = "#ddd";
    ctx.beginPath();
    this.points.forEach((p, i) => {
      const [x, y] = this.toCanvas(p);
      if (i === 0) ctx.moveTo(x, y);
      else ctx.lineTo(x, y);
    });
    ctx.stroke();
    for (const p of this.points) {
      const [x, y] = this.toCanvas(p);
      ctx.fillStyle = `rgb(${p[1] * 255},${p[2] * 255},${p[3] * 255})`;
      ctx.beginPath();
      ctx.arc(x, y, RADIUS, 0, 2 * Math.PI);
      ctx.fill();
      ctx.stroke();
    }
    ctx.globalAlpha = 1;
  }
}
