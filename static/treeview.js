// Draws a SearchTree on a <canvas>: pan (drag), zoom (wheel), pick (click).
//
// Nodes are batched by colour so a 20,000-node tree is a handful of canvas paths. World
// coordinates are (leaf slot, level); the view maps them to CSS pixels with separate x and y
// scales, because search trees are far wider than they are deep. A gutter on the left names
// each row (its stream); zoomed in, nodes carry their id and label; a node's failed leaves are
// one fan ("✕ 12"), opened by a click. Colours are planner/figures.py's scale of Q.

import { NO_PREDICTION_RGB, Q_PERCENTILES, Q_STOPS } from "/generated/definitions.js";
import { count } from "./format.js";

const BUCKETS = 12; // colour steps between the lowest and the highest predicted Q
const GREY = rgb(NO_PREDICTION_RGB); // no prediction
const EDGE = "#c9ced6";
const FAILED = "#dc2626";
const SOLUTION = "#2563eb";
const SELECTED = "#111827";
const MATCH = "#f59e0b"; // nodes the search found
const PAD = 28; // CSS px around the fitted tree
const PAD_TOP = 46; // and above it, below the overlay (search, counts)
const PAD_BOTTOM = 44; // and above the legend
const MAX_SX = 90; // CSS px per leaf slot when fitted
const MAX_SY = 70; // CSS px per level when fitted
const ROW_LABEL_PX = 11; // rows closer than this label every other one (or fewer)
const LABEL_FULL_SX = 110; // CSS px per slot that centreOn zooms to: room for a label

/** Green (low Q) through yellow to red (high Q), as BUCKETS css colours. */
export const Q_COLOURS = Array.from({ length: BUCKETS }, (_, i) => rgb(qRgbAt(i / (BUCKETS - 1))));

/** The colour at ``f`` (0 green .. 1 red) along planner/figures.py's Q_STOPS. */
export function qRgbAt(f) {
  const pos = Math.min(Math.max(f, 0), 1) * (Q_STOPS.length - 1);
  const i = Math.min(Math.floor(pos), Q_STOPS.length - 2);
  const u = pos - i;
  return Q_STOPS[i].map((a, j) => Math.round(a + (Q_STOPS[i + 1][j] - a) * u));
}

function rgb(c) {
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}

/** The CSS gradient of the Q scale (the legend's ramp). */
export function qGradient() {
  return `linear-gradient(90deg, ${Q_STOPS.map(rgb).join(", ")})`;
}

/**
 * planner/figures.py's q_scale: the Q_PERCENTILES (nearest rank) of the Q values predicted in
 * the tree, or null without any.
 */
export function qScaleOf(tree) {
  if (tree.predicted === 0) return null;
  const qs = new Float64Array(tree.predicted);
  let m = 0;
  for (const node of tree.order) {
    if (node.pred !== null && m < qs.length) qs[m++] = node.pred.q;
  }
  if (m === 0) return null;
  const sorted = qs.subarray(0, m).sort();
  return {
    lo: sorted[Math.floor((Q_PERCENTILES[0] / 100) * (m - 1))],
    hi: sorted[Math.ceil((Q_PERCENTILES[1] / 100) * (m - 1))],
  };
}

export class TreeView {
  constructor(canvas, { onSelect, onHover, onViewChange, gutter = true } = {}) {
    this.canvas = canvas;
    this.ctx = canvas.getContext("2d");
    this.tree = null;
    this.selectedId = null;
    this.view = { sx: 1, sy: 1, tx: 0, ty: 0 };
    this.autoFit = true; // refit whenever the tree grows, until the user pans or zooms
    this.onSelect = onSelect ?? (() => {});
    this.onHover = onHover ?? (() => {});
    this.onViewChange = onViewChange ?? (() => {});
    this.gutter = gutter; // row labels on the left
    this.qRange = null; // {lo, hi} of the predicted Q drawn last
    this.scale = null; // {lo, hi}: a colour scale given from outside (two trees, one scale)
    this.marks = new Map(); // node id -> colour of an extra ring (where two searches parted)
    this.matches = new Set(); // node ids the search found, ringed
    this._frame = 0;
    this._buckets = Array.from({ length: BUCKETS + 1 }, () => []);
    this._rowText = new Map(); // a row label's text fitted to the gutter, by what it says
    this._bind();
  }

  /** A new tree: nothing of the previous one is kept, and it is drawn at the next frame. */
  setTree(tree) {
    this.tree = tree;
    this.autoFit = true;
    this.selectedId = null;
    this.matches = new Set();
    this.marks = new Map();
    this.qRange = null;
    this._q = null;
    this.requestDraw();
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
    // The size the ResizeObserver last saw (reading clientWidth after the page changed text
    // forced a layout of the whole page on every step).
    if (this._box === undefined) this._box = { w: this.canvas.clientWidth, h: this.canvas.clientHeight };
    const { w, h } = this._box;
    if (this.canvas.width !== Math.round(w * dpr) || this.canvas.height !== Math.round(h * dpr)) {
      this.canvas.width = Math.round(w * dpr);
      this.canvas.height = Math.round(h * dpr);
    }
    return { w, h, dpr };
  }

  _gutterWidth(w) {
    if (!this.gutter) return 0;
    return w < 560 ? 118 : 150;
  }

  _fit(w, h) {
    const tree = this.tree;
    const left = this._gutterWidth(w) + PAD;
    const spanX = Math.max(tree.leaves - 1, 1);
    const spanY = Math.max(tree.maxLevel, 1);
    const sx = Math.min((w - left - PAD) / spanX, MAX_SX);
    const sy = Math.min((h - PAD_TOP - PAD_BOTTOM) / spanY, MAX_SY);
    this.view = {
      sx: Math.max(sx, 1e-4),
      sy: Math.max(sy, 1e-4),
      tx: left + (w - left - PAD - sx * (tree.leaves - 1)) / 2,
      ty: PAD_TOP,
    };
  }

  /** The colour scale the tree is drawn on now (a given one, else the tree's own). */
  scaleOf(tree = this.tree) {
    if (this.scale !== null) return this.scale;
    if (tree === null) return null;
    if (this._q && this._q.tree === tree && this._q.version === tree.predVersion) return this._q.range;
    this._q = { tree, version: tree.predVersion, range: qScaleOf(tree) };
    return this._q.range;
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

    // Edges: one path (a folded node's edge is its fan's, drawn once below).
    ctx.beginPath();
    for (let i = 1; i < n; i++) {
      const node = nodes[i];
      if (node.folded) continue;
      const p = node.parent;
      const cx = tx + node.x * sx;
      const px = tx + p.x * sx;
      if ((cx < x0 && px < x0) || (cx > x1 && px > x1)) continue;
      ctx.moveTo(px, ty + p.level * sy);
      ctx.lineTo(cx, ty + node.level * sy);
    }
    for (const fan of tree.fans) {
      const p = fan.parent;
      ctx.moveTo(tx + p.x * sx, ty + p.level * sy);
      ctx.lineTo(tx + fan.x * sx, ty + fan.level * sy);
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

    const range = this.scaleOf(tree);
    this.qRange = range;
    const lo = range?.lo ?? 0;
    const scale = range && range.hi > range.lo ? (BUCKETS - 1) / (range.hi - range.lo) : 0;
    if (range) tree.effectiveQ();

    // Nodes batched by colour bucket (index BUCKETS = grey).
    const buckets = this._buckets;
    for (const b of buckets) b.length = 0;
    const failed = [];
    const y0 = -r - 2;
    const y1 = h + r + 2;
    for (let i = 0; i < n; i++) {
      const node = nodes[i];
      if (node.folded) continue;
      const x = tx + node.x * sx;
      if (x < x0 || x > x1) continue;
      const y = ty + node.level * sy;
      if (y < y0 || y > y1) continue;
      let b = BUCKETS;
      const q = range ? node.effQ : null;
      if (q !== null) {
        b = Math.round((q - lo) * scale);
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

    this._fans(ctx, tree, r, w, h);

    // Labels where there is room for them.
    this._labels(ctx, nodes, r, w, h);

    // The solution leaf, the search's matches, the marks and the selected node get rings.
    if (tree.solution !== null) this._ring(tree.byId.get(tree.solution.node_id), r + 3, SOLUTION);
    for (const id of this.matches) this._ring(tree.byId.get(id), r + 5, MATCH, 2.5);
    for (const [id, colour] of this.marks) this._ring(tree.byId.get(id), r + 6, colour, 3);
    if (this.selectedId !== null) this._ring(tree.byId.get(this.selectedId), r + 4, SELECTED);

    this._rowLabels(ctx, tree, w, h);
  }

  /** A fan of folded failed leaves: a red diamond with its count. */
  _fans(ctx, tree, r, w, h) {
    if (tree.fans.length === 0) return;
    const { sx, sy, tx, ty } = this.view;
    const d = Math.max(r + 2, 4);
    ctx.beginPath();
    const shown = [];
    for (const fan of tree.fans) {
      const x = tx + fan.x * sx;
      const y = ty + fan.level * sy;
      if (x < -d || x > w + d || y < -d || y > h + d) continue;
      ctx.moveTo(x, y - d);
      ctx.lineTo(x + d, y);
      ctx.lineTo(x, y + d);
      ctx.lineTo(x - d, y);
      ctx.closePath();
      shown.push([x, y, fan.nodes.length]);
    }
    ctx.fillStyle = "#fee2e2";
    ctx.fill();
    ctx.strokeStyle = FAILED;
    ctx.lineWidth = 1.5;
    ctx.stroke();
    if (sx >= 18 && sy >= 12) {
      ctx.font = "600 10px system-ui, sans-serif";
      ctx.textAlign = "center";
      ctx.textBaseline = "top";
      ctx.fillStyle = FAILED;
      for (const [x, y, n] of shown.slice(0, 3000)) ctx.fillText(`✕${n}`, x, y + d + 2);
    }
  }

  /** Zoom in on node ``id`` and put it in the middle of the canvas. */
  centreOn(id, zoom = 6) {
    const node = this.tree?.byId.get(id);
    if (node === undefined) return;
    const { w, h } = this._size();
    if (this.tree.unfold(node) || this.tree.layoutDirty) this.tree.layout();
    if (this.autoFit) this._fit(w, h);
    this.autoFit = false;
    const v = this.view;
    v.sx = Math.min(Math.max(v.sx * zoom, LABEL_FULL_SX), 160);
    v.sy = Math.min(Math.max(v.sy, 28), 80);
    v.tx = w / 2 - node.x * v.sx;
    v.ty = h / 2 - node.level * v.sy;
    this.requestDraw();
    this.onViewChange();
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

  /**
   * Node ids, and labels where there is room, to the right of each node: a node is labelled
   * when its row leaves it room before the next node to its right (zoomed in, every node; a
   * deep branch, which is one vertical line when the tree is fitted, all along).
   */
  _labels(ctx, nodes, r, w, h) {
    const { sx, sy, tx, ty } = this.view;
    if (sy < 12) return;
    const rows = new Map();
    let seen = 0;
    for (const node of nodes) {
      if (node.folded) continue;
      const x = tx + node.x * sx;
      const y = ty + node.level * sy;
      if (x < -sx - 200 || x > w || y < -sy || y > h + sy) continue;
      let row = rows.get(node.level);
      if (row === undefined) rows.set(node.level, (row = []));
      row.push(node);
      if (++seen > 3000) return; // too many on screen to read any label
    }
    ctx.font = "11px system-ui, sans-serif";
    ctx.textAlign = "left";
    ctx.textBaseline = "middle";
    const left = this._gutterWidth(w);
    let drawn = 0;
    for (const row of rows.values()) {
      row.sort((a, b) => a.x - b.x);
      for (let i = 0; i < row.length; i++) {
        const node = row[i];
        const x = tx + node.x * sx;
        const next = i + 1 < row.length ? tx + row[i + 1].x * sx - r - 4 : w - 2;
        const room = next - (x + r + 3);
        if (room < 26 || x + r + 3 < left) continue;
        const y = ty + node.level * sy;
        const text = fitText(ctx, `#${node.id} ${nodeText(node)}`, room);
        const width = ctx.measureText(text).width;
        ctx.fillStyle = "rgba(252,253,254,0.85)";
        ctx.fillRect(x + r + 2, y - 7, width + 2, 13);
        ctx.fillStyle = node.success ? "#374151" : FAILED;
        ctx.fillText(text, x + r + 3, y);
        if (++drawn > 3000) return;
      }
    }
  }

  /** The gutter: each row's stream (most frequent first, how many, and how many others). */
  _rowLabels(ctx, tree, w, h) {
    const gw = this._gutterWidth(w);
    if (gw === 0) return;
    const { sy, ty } = this.view;
    ctx.fillStyle = "rgba(248,250,252,0.94)";
    ctx.fillRect(0, 0, gw, h);
    ctx.strokeStyle = "#e5e7eb";
    ctx.beginPath();
    ctx.moveTo(gw + 0.5, 0);
    ctx.lineTo(gw + 0.5, h);
    ctx.stroke();
    const every = Math.max(1, Math.ceil(ROW_LABEL_PX / Math.max(sy, 1e-6)));
    ctx.textAlign = "right";
    ctx.textBaseline = "middle";
    const numbered = gw >= 150; // "3. ik": the plan's third stream, where there is room
    const twoLines = sy >= 26;
    this.rowsDrawn = [];
    ctx.font = "11px system-ui, sans-serif"; // set once: a font is parsed each time it is set
    ctx.fillStyle = "#374151";
    for (let level = 0; level < tree.rows.length; level += every) {
      const y = ty + level * sy;
      if (y < -6 || y > h + 6) continue;
      const row = tree.rows[level];
      if (!row || row.length === 0) continue;
      const [name, most] = row[0];
      const more = row.length > 1 ? ` +${row.length - 1}` : "";
      const lead = numbered && level >= 2 ? `${level - 1}. ` : "";
      const memo = `${gw}|${lead}${name}|${more}`;
      let text = this._rowText.get(memo);
      if (text === undefined) {
        text = fitText(ctx, lead + name, gw - 10 - ctx.measureText(more).width) + more;
        if (this._rowText.size > 5000) this._rowText.clear();
        this._rowText.set(memo, text);
      }
      ctx.fillText(text, gw - 6, y - (twoLines ? 6 : 0));
      this.rowsDrawn.push({ level, y, text, name, count: most, row });
    }
    if (twoLines) {
      ctx.font = "10px system-ui, sans-serif";
      ctx.fillStyle = "#6b7280";
      for (const { y, row } of this.rowsDrawn) {
        const total = row.reduce((a, [, c]) => a + c, 0);
        ctx.fillText(`${count(total)} node${total === 1 ? "" : "s"}`, gw - 6, y + 7);
      }
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

  /** The node (or fan: {fan}) nearest to a CSS-pixel point within a few pixels, or null. */
  pick(px, py) {
    const tree = this.tree;
    if (tree === null || tree.nodeCount === 0) return null;
    if (px < this._gutterWidth(this.canvas.clientWidth)) return null;
    const { sx, sy, tx, ty } = this.view;
    let best = null;
    let bestD = 10 * 10; // within 10 px
    for (const node of tree.order) {
      if (node.folded) continue;
      const dx = tx + node.x * sx - px;
      const dy = ty + node.level * sy - py;
      const d = dx * dx + dy * dy;
      if (d < bestD) {
        bestD = d;
        best = node;
      }
    }
    for (const fan of tree.fans) {
      const dx = tx + fan.x * sx - px;
      const dy = ty + fan.level * sy - py;
      const d = dx * dx + dy * dy;
      if (d < bestD) {
        bestD = d;
        best = { fan };
      }
    }
    return best;
  }

  /** Where the fan below node ``parentId`` is drawn (CSS px, relative to the canvas), or null. */
  fanPosition(parentId) {
    const tree = this.tree;
    if (tree === null) return null;
    if (tree.layoutDirty || this.autoFit) this.draw();
    const fan = tree.fans.find((f) => f.parent.id === parentId);
    if (!fan) return null;
    const { sx, sy, tx, ty } = this.view;
    return { x: tx + fan.x * sx, y: ty + fan.level * sy };
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
        const hit = this.pick(e.clientX - rect.left, e.clientY - rect.top);
        if (hit !== null && hit.fan) {
          this.tree.toggleFan(hit.fan.parent.id); // a click opens a fan
          this.requestDraw();
          this.onViewChange();
        } else {
          this.selectedId = hit ? hit.id : null;
          this.requestDraw();
          this.onSelect(hit);
        }
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
    new ResizeObserver((entries) => {
      const box = entries.at(-1).contentRect;
      this._box = { w: box.width, h: box.height };
      this.requestDraw();
    }).observe(canvas);
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

/** ``text`` cut with an ellipsis to fit ``room`` CSS px in the context's font. */
function fitText(ctx, text, room) {
  if (ctx.measureText(text).width <= room) return text;
  let lo = 0;
  let hi = text.length;
  while (lo < hi) {
    const mid = (lo + hi + 1) >> 1;
    if (ctx.measureText(`${text.slice(0, mid)}…`).width <= room) lo = mid;
    else hi = mid - 1;
  }
  return lo === 0 ? "" : `${text.slice(0, lo)}…`;
}

/** The few words drawn under a node. */
export function shortLabel(node) {
  if (node.parent === null) return "root";
  if (node.stream === null) return `plan ${node.planIndex}`;
  return node.stream;
}

/** A node's label as the tree shows it zoomed in: its event's label, else its stream. */
export function nodeText(node) {
  if (node.parent === null) return "root";
  if (node.stream === null) return `plan ${node.planIndex}`;
  return node.label || node.stream;
}
