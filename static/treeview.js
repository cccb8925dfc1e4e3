// Draws a SearchTree on a <canvas>: pan (drag), zoom (wheel), pick (click).
//
// Nodes are batched by colour so a 20,000-node tree is a handful of canvas paths. World
// coordinates are (leaf slot, level); the view maps them to CSS pixels with separate x and y
// scales, because search trees are far wider than they are deep.

const BUCKETS = 12; // colour steps between the lowest and the highest predicted Q
const GREY = "#9aa3ae"; // no prediction
const EDGE = "#c9ced6";
const FAILED = "#dc2626";
const SOLUTION = "#2563eb";
const SELECTED = "#111827";
const PAD = 28; // CSS px around the fitted tree
const PAD_BOTTOM = 44; // and above the legend
const MAX_SX = 90; // CSS px per leaf slot when fitted
const MAX_SY = 70; // CSS px per level when fitted

/** Green (low Q) through yellow to red (high Q), as BUCKETS css colours. */
export const Q_COLOURS = Array.from({ length: BUCKETS }, (_, i) => qColour(i / (BUCKETS - 1)));

function qColour(f) {
  const stops = [
    [26, 152, 80],
    [166, 217, 106],
    [254, 224, 139],
    [244, 109, 67],
    [215, 48, 39],
  ];
  const pos = f * (stops.length - 1);
  const i = Math.min(Math.floor(pos), stops.length - 2);
  const u = pos - i;
  const c = stops[i].map((a, j) => Math.round(a + (stops[i + 1][j] - a) * u));
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}

export class TreeView {
  constructor(canvas, { onSelect, onHover, onViewChange } = {}) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.tree = null;
    this.selectedId = null;
    this.view = { sx: 1, sy: 1, tx: 0, ty: 0 };
    this.autoFit = true; // refit whenever the tree grows, until the user pans or zooms
    this.onSelect = onSelect ?? (() => {});
    this.onHover = onHover ?? (() => {});
    this.onViewChange = onViewChange ?? (() => {});
    this.qRange = null; // {lo, hi} of the predicted Q drawn last
    this.scale = null; // {lo, hi}: a colour scale given from outside (two trees, one scale)
    this.marks = new Map(); // node id -> colour of an extra ring (where two searches parted)
    this._frame = 0;
    this._buckets = Array.from({ length: BUCKETS + 1 }, () => []);
    this._bind();
  }

  setTree(tree) {
    this.tree = tree;
    this.autoFit = true;
    this.selectedId = null;
  }

  /** Draw at the next animation frame (many calls in one frame draw once). */
  requestDraw() {
    if (this._frame) return;
    this._frame = requestAnimationFrame(() => {
      this._frame = 0;
      this.draw();
    });
  }

  fit() {
    this.autoFit = true;
    this.requestDraw();
    this.onViewChange();
  }

  _size() {
    const dpr = window.devicePixelRatio || 1;
    const w = this.canvas.clientWidth;
    const h = this.canvas.clientHeight;
    if (this.canvas.width !== Math.round(w * dpr) || this.canvas.height !== Math.round(h * dpr)) {
      this.canvas.width = Math.round(w * dpr);
      this.canvas.height = Math.round(h * dpr);
    }
    return { w, h, dpr };
  }

  _fit(w, h) {
    const tree = this.tree;
    const spanX = Math.max(tree.leaves - 1, 1);
    const spanY = Math.max(tree.maxLevel, 1);
    const sx = Math.min((w - 2 * PAD) / spanX, MAX_SX);
    const sy = Math.min((h - PAD - PAD_BOTTOM) / spanY, MAX_SY);
    this.view = {
      sx: Math.max(sx, 1e-4),
      sy: Math.max(sy, 1e-4),
      tx: (w - sx * (tree.leaves - 1)) / 2,
      ty: PAD,
    };
  }

  /** Draw now (layout first if the tree changed). */
  draw() {
    const { w, h, dpr } = this._size();
    const ctx = this.ctx;
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.clearRect(0, 0, w, h);
    const tree = this.tree;
    if (tree === null || tree.nodeCount === 0) {
      this.qRange = null;
      return;
    }
    if (tree.layoutDirty) tree.layout();
    if (this.autoFit) this._fit(w, h);
    const { sx, sy, tx, ty } = this.view;
    const nodes = tree.order;
    const n = nodes.length;
    const r = Math.max(1.5, Math.min(6, Math.min(sx, sy) * 0.3));
    const x0 = -r - 2;
    const x1 = w + r + 2;

    // Edges: one path.
    ctx.beginPath();
    for (let i = 1; i < n; i++) {
      const node = nodes[i];
      const p = node.parent;
      const cx = tx + node.x * sx;
      const px = tx + p.x * sx;
      if ((cx < x0 && px < x0) || (cx > x1 && px > x1)) continue;
      ctx.moveTo(px, ty + p.level * sy);
      ctx.lineTo(cx, ty + node.level * sy);
    }
    ctx.strokeStyle = EDGE;
    ctx.lineWidth = 1;
    ctx.stroke();

    // The solution path on top of the edges.
    const path = tree.solutionPath();
    if (path.size > 1) {
      ctx.beginPath();
      let node = tree.byId.get(tree.solution.node_id);
      ctx.moveTo(tx + node.x * sx, ty + node.level * sy);
      while (node.parent) {
        node = node.parent;
        ctx.lineTo(tx + node.x * sx, ty + node.level * sy);
      }
      ctx.strokeStyle = SOLUTION;
      ctx.lineWidth = 3.5;
      ctx.lineJoin = "round";
      ctx.stroke();
    }

    const { lo, hi } = this._qScale(tree);
    this.qRange = lo <= hi ? { lo, hi } : null;
    const scale = hi > lo ? (BUCKETS - 1) / (hi - lo) : 0;

    // Nodes batched by colour bucket (index BUCKETS = grey).
    const buckets = this._buckets;
    for (const b of buckets) b.length = 0;
    const failed = [];
    const y0 = -r - 2;
    const y1 = h + r + 2;
    for (let i = 0; i < n; i++) {
      const node = nodes[i];
      const x = tx + node.x * sx;
      if (x < x0 || x > x1) continue;
      const y = ty + node.level * sy;
      if (y < y0 || y > y1) continue;
      let b = BUCKETS;
      if (node.pred !== null) {
        b = Math.round((node.pred.q - lo) * scale);
        b = b < 0 ? 0 : b > BUCKETS - 1 ? BUCKETS - 1 : b;
      }
      buckets[b].push(x, y);
      if (!node.success) failed.push(x, y);
    }
    const round = r >= 3;
    for (let b = 0; b <= BUCKETS; b++) {
      const pts = buckets[b];
      if (pts.length === 0) continue;
      ctx.beginPath();
      for (let j = 0; j < pts.length; j += 2) {
        if (round) {
          ctx.moveTo(pts[j] + r, pts[j + 1]);
          ctx.arc(pts[j], pts[j + 1], r, 0, 2 * Math.PI);
        } else {
          ctx.rect(pts[j] - r, pts[j + 1] - r, 2 * r, 2 * r);
        }
      }
      ctx.fillStyle = b === BUCKETS ? GREY : Q_COLOURS[b];
      ctx.fill();
    }

    // Failed queries: a red cross over the node.
    if (failed.length > 0) {
      const c = r < 2.5 ? r + 0.5 : r + 1.5; // dense trees: no wider than the node itself
      ctx.beginPath();
      for (let j = 0; j < failed.length; j += 2) {
        const x = failed[j];
        const y = failed[j + 1];
        ctx.moveTo(x - c, y - c);
        ctx.lineTo(x + c, y + c);
        ctx.moveTo(x + c, y - c);
        ctx.lineTo(x - c, y + c);
      }
      ctx.strokeStyle = FAILED;
      ctx.lineWidth = r >= 3 ? 2 : 1.5;
      ctx.stroke();
    }

    // Labels once there is room for them.
    if (sx >= 64 && sy >= 28) this._labels(ctx, nodes, r, w, h);

    // The solution leaf and the selected node get rings.
    if (tree.solution !== null) this._ring(tree.byId.get(tree.solution.node_id), r + 3, SOLUTION);
    for (const [id, colour] of this.marks) this._ring(tree.byId.get(id), r + 6, colour, 3);
    if (this.selectedId !== null) this._ring(tree.byId.get(this.selectedId), r + 4, SELECTED);
  }

  /** Zoom in on node ``id`` and put it in the middle of the canvas. */
  centreOn(id, zoom = 6) {
    const node = this.tree?.byId.get(id);
    if (node === undefined) return;
    const { w, h } = this._size();
    if (this.tree.layoutDirty) this.tree.layout();
    if (this.autoFit) this._fit(w, h);
    this.autoFit = false;
    const v = this.view;
    v.sx = Math.min(v.sx * zoom, MAX_SX);
    v.sy = Math.min(Math.max(v.sy, 24), 80);
    v.tx = w / 2 - node.x * v.sx;
    v.ty = h / 2 - node.level * v.sy;
    this.requestDraw();
    this.onViewChange();
  }

  /**
   * The Q values mapped to green and red: the 2nd and 98th percentiles of the predicted Q of
   * the nodes in the tree (one outlier, e.g. a P_S near 0, must not wash the others out).
   * Recomputed only when a prediction changed.
   */
  _qScale(tree) {
    if (this.scale !== null) return this.scale;
    if (this._q && this._q.tree === tree && this._q.version === tree.predVersion) return this._q;
    let lo = Infinity;
    let hi = -Infinity;
    if (tree.predicted > 0) {
      const qs = new Float64Array(tree.predicted);
      let m = 0;
      for (const node of tree.order) {
        if (node.pred !== null && m < qs.length) qs[m++] = node.pred.q;
      }
      const sorted = qs.subarray(0, m).sort();
      lo = sorted[Math.floor(0.02 * (m - 1))];
      hi = sorted[Math.ceil(0.98 * (m - 1))];
    }
    this._q = { tree, version: tree.predVersion, lo, hi };
    return this._q;
  }

  _ring(node, radius, colour, width = 2) {
    if (node === undefined) return;
    const { sx, sy, tx, ty } = this.view;
    const ctx = this.ctx;
    ctx.beginPath();
    ctx.arc(tx + node.x * sx, ty + node.level * sy, radius, 0, 2 * Math.PI);
    ctx.strokeStyle = colour;
    ctx.lineWidth = width;
    ctx.stroke();
  }

  _labels(ctx, nodes, r, w, h) {
    const { sx, sy, tx, ty } = this.view;
    ctx.font = "11px system-ui, sans-serif";
    ctx.textAlign = "center";
    ctx.textBaseline = "top";
    ctx.fillStyle = "#374151";
    const maxChars = Math.max(4, Math.floor(sx / 6.5));
    let drawn = 0;
    for (const node of nodes) {
      const x = tx + node.x * sx;
      const y = ty + node.level * sy;
      if (x < -sx || x > w + sx || y < -sy || y > h) continue;
      let text = shortLabel(node);
      if (text.length > maxChars) text = `${text.slice(0, maxChars - 1)}…`;
      ctx.fillText(text, x, y + r + 3);
      if (++drawn > 2000) break;
    }
  }

  /** Screen position (CSS px, relative to the canvas) of a node, or null. */
  position(id) {
    const node = this.tree?.byId.get(id);
    if (node === undefined || (node.implicit && this.tree.nodeCount === 0)) return null;
    if (this.tree.layoutDirty || this.autoFit) this.draw(); // the view it will be drawn in
    const { sx, sy, tx, ty } = this.view;
    return { x: tx + node.x * sx, y: ty + node.level * sy };
  }

  /** The node nearest to a CSS-pixel point within a few pixels, or null. */
  pick(px, py) {
    const tree = this.tree;
    if (tree === null || tree.nodeCount === 0) return null;
    const { sx, sy, tx, ty } = this.view;
    let best = null;
    let bestD = 10 * 10; // within 10 px
    for (const node of tree.order) {
      const dx = tx + node.x * sx - px;
      const dy = ty + node.level * sy - py;
      const d = dx * dx + dy * dy;
      if (d < bestD) {
        bestD = d;
        best = node;
      }
    }
    return best;
  }

  _bind() {
    const canvas = this.canvas;
    let drag = null;
    canvas.addEventListener("pointerdown", (e) => {
      drag = { x: e.clientX, y: e.clientY, moved: false };
      canvas.setPointerCapture(e.pointerId);
    });
    canvas.addEventListener("pointermove", (e) => {
      if (drag !== null) {
        const dx = e.clientX - drag.x;
        const dy = e.clientY - drag.y;
        if (!drag.moved && Math.abs(dx) + Math.abs(dy) < 4) return;
        drag.moved = true;
        drag.x = e.clientX;
        drag.y = e.clientY;
        this.autoFit = false;
        this.view.tx += dx;
        this.view.ty += dy;
        canvas.classList.add("panning");
        this.requestDraw();
        this.onViewChange();
        return;
      }
      const rect = canvas.getBoundingClientRect();
      this.onHover(this.pick(e.clientX - rect.left, e.clientY - rect.top), e);
    });
    canvas.addEventListener("pointerup", (e) => {
      canvas.classList.remove("panning");
      if (drag !== null && !drag.moved) {
        const rect = canvas.getBoundingClientRect();
        const node = this.pick(e.clientX - rect.left, e.clientY - rect.top);
        this.selectedId = node ? node.id : null;
        this.requestDraw();
        this.onSelect(node);
      }
      drag = null;
    });
    canvas.addEventListener("pointerleave", () => this.onHover(null));
    canvas.addEventListener(
      "wheel",
      (e) => {
        e.preventDefault();
        const rect = canvas.getBoundingClientRect();
        this.zoom(Math.exp(-e.deltaY * 0.0015), e.clientX - rect.left, e.clientY - rect.top);
      },
      { passive: false },
    );
    canvas.addEventListener("dblclick", () => this.fit());
    new ResizeObserver(() => this.requestDraw()).observe(canvas);
  }

  /** Zoom by ``factor`` around a CSS-pixel point; levels stop growing at a readable height. */
  zoom(factor, px, py) {
    const v = this.view;
    this.autoFit = false;
    const sy = Math.min(Math.max(v.sy * factor, 6), 80);
    v.tx = px - (px - v.tx) * factor;
    v.ty = py - (py - v.ty) * (sy / v.sy);
    v.sx *= factor;
    v.sy = sy;
    this.requestDraw();
    this.onViewChange();
  }
}

/** The few words drawn under a node. */
export function shortLabel(node) {
  if (node.parent === null) return "root";
  if (node.stream === null) return `plan ${node.planIndex}`;
  return node.stream;
}
