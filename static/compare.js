// The compare view (#compare=A,B): two runs' trees side by side on one colour scale, their time
// splits, their queries per stream and outcome, queries made against planning seconds, and
// where the two searches chose differently. Everything comes from GET /api/compare and
// GET /api/runs/{id}/tree (app/compare.py).

import { api } from "./api.js";
import { escapeHtml, seconds } from "./format.js";
import { treeFromColumns } from "./tree.js";
import { TreeView, shortLabel } from "./treeview.js";

const PARTED = "#a21caf"; // the ring on the nodes where the searches parted
const OUTCOME = "#f59e0b"; // the ring on a query both made alike that ended otherwise
const COLOURS = { a: "#2563eb", b: "#ea580c" };
const FIXED = { skeletons: "#6366f1", "search overhead": "#94a3b8", execution: "#0ea5e9" }; // as charts.js
const CONFIG = { displayModeBar: false, responsive: true };
const FONT = { family: "system-ui, -apple-system, Segoe UI, sans-serif", size: 12, color: "#1f2937" };

const $ = (id) => document.getElementById(id);

export class CompareView {
  constructor() {
    this.el = {
      header: $("compare-header"),
      notes: $("compare-notes"),
      divergence: $("compare-divergence"),
      scale: $("compare-scale"),
      split: $("compare-split"),
      curve: $("compare-curve"),
      queries: $("compare-queries"),
      tooltip: $("compare-tooltip"),
    };
    this.views = {};
    for (const side of ["a", "b"]) {
      const canvas = $(`compare-canvas-${side}`);
      this.views[side] = new TreeView(canvas, {
        onSelect: (node) => this._select(side, node),
        onHover: (node, e) => this._hover(canvas, node, e),
      });
    }
    this.key = "";
    this.data = null;
    this.trees = {};
    this.ms = null; // milliseconds from asking the server to both trees drawn
  }

  /** Show runs ``a`` and ``b`` (the page's hash said so); nothing new if already shown. */
  async show(a, b) {
    const key = `${a},${b}`;
    if (key === this.key) {
      for (const v of Object.values(this.views)) v.requestDraw();
      return;
    }
    this.key = key;
    const t0 = performance.now();
    this.el.header.innerHTML = `<span class="muted">Loading runs ${escapeHtml(a.slice(0, 8))} and ${escapeHtml(b.slice(0, 8))}…</span>`;
    this.el.notes.innerHTML = "";
    this.el.divergence.textContent = "";
    document.body.dataset.compare = "loading";
    let data;
    let cols;
    try {
      const enc = encodeURIComponent;
      [data, ...cols] = await Promise.all([
        api(`/api/compare?a=${enc(a)}&b=${enc(b)}`),
        api(`/api/runs/${enc(a)}/tree`),
        api(`/api/runs/${enc(b)}/tree`),
      ]);
    } catch (err) {
      if (key !== this.key) return;
      this.el.header.innerHTML = `<span class="error-text" data-testid="compare-error">Cannot compare: ${escapeHtml(err.message)}</span>`;
      document.body.dataset.compare = "error";
      return;
    }
    if (key !== this.key) return;
    this.data = data;
    const scale = data.q_scale ? { lo: data.q_scale[0], hi: data.q_scale[1] } : null;
    for (const [i, side] of ["a", "b"].entries()) {
      const tree = treeFromColumns(cols[i]);
      this.trees[side] = tree;
      const view = this.views[side];
      view.setTree(tree);
      view.scale = scale;
      view.marks = new Map();
      const div = data.divergence;
      if (div[side]) view.marks.set(div[side].node_id, PARTED);
      if (div.outcome) view.marks.set(div.outcome[side].node_id, OUTCOME);
      view.draw();
      $(`compare-count-${side}`).textContent = `${side.toUpperCase()}: ${tree.nodeCount.toLocaleString()} nodes`;
      $(`compare-count-${side}`).dataset.nodes = String(tree.nodeCount);
    }
    this._header(data);
    this._divergence(data);
    this.el.scale.textContent = scale ? `Q from ${seconds(scale.lo)} to ${seconds(scale.hi)}.` : "Neither run has model predictions.";
    this._split(data);
    this._curve(data);
    this._queries(data);
    this.ms = performance.now() - t0;
    document.body.dataset.compare = "drawn";
  }

  _header(data) {
    const side = (s) => {
      const r = data[s].run;
      return `<div class="compare-run" data-testid="compare-run-${s}">
        <span class="swatch" style="background:${COLOURS[s]}"></span>
        <b>${s.toUpperCase()}</b>
        <a href="#run=${encodeURIComponent(r.id)}" title="${escapeHtml(r.id)}">${escapeHtml(r.id.slice(0, 8))}</a>
        ${escapeHtml(r.scene)} · <b>${escapeHtml(r.planner)}</b> · seed ${escapeHtml(r.seed)}
        <span class="badge ${escapeHtml(r.status)}">${escapeHtml(r.status)}</span>
        planning <b>${seconds(r.planning_s)}</b> · execution <b>${seconds(r.execution_s)}</b> ·
        ${r.queries ?? 0} queries · ${data[s].nodes.toLocaleString()} nodes
      </div>`;
    };
    this.el.header.innerHTML = side("a") + side("b");
    this.el.notes.innerHTML = data.notes.map((n) => `<li>${escapeHtml(n)}</li>`).join("");
  }

  _divergence(data) {
    const div = data.divergence;
    let html = escapeHtml(div.text);
    if (div.a || div.b || div.outcome) {
      html += ` <button type="button" class="link" data-testid="compare-show-parting">show it in both trees</button>`;
    }
    this.el.divergence.innerHTML = html;
    this.el.divergence.dataset.kind = div.kind;
    const button = this.el.divergence.querySelector("button");
    if (button) {
      button.addEventListener("click", () => {
        for (const side of ["a", "b"]) {
          const ref = div[side] ?? div.outcome?.[side];
          if (ref) {
            this.views[side].selectedId = ref.node_id;
            this.views[side].centreOn(ref.node_id);
          }
        }
      });
    }
  }

  _split(data) {
    if (!window.Plotly) return;
    const parts = (s) => {
      const split = data[s].split;
      const out = [["skeletons", split.until_plans_s + (split.later_skeletons_s ?? 0)]];
      for (const [stream, secs] of Object.entries(split.queries_by_stream_s)) out.push([`queries: ${stream}`, secs]);
      out.push(["search overhead", Math.max(split.search_s, 0)]);
      out.push(["execution", split.execution_s ?? 0]);
      return out;
    };
    const names = [...new Set([...parts("a"), ...parts("b")].map(([n]) => n))];
    const traces = names.map((name, i) => ({
      type: "bar",
      orientation: "h",
      name,
      y: ["B", "A"],
      x: ["b", "a"].map((s) => parts(s).find(([n]) => n === name)?.[1] ?? 0),
      marker: { color: FIXED[name] ?? `hsl(${(i * 53) % 360}, 60%, 58%)` },
      hovertemplate: `${name}: %{x:.3f} s<extra>%{y}</extra>`,
    }));
    const so = (s) => (data[s].split.so_far ? " (so far)" : "");
    window.Plotly.react(
      this.el.split,
      traces,
      {
        barmode: "stack",
        title: { text: `Time split: A ${seconds(data.a.split.planning_s)}${so("a")}, B ${seconds(data.b.split.planning_s)}${so("b")} planning`, x: 0.02, font: { size: 13 } },
        font: FONT,
        margin: { l: 30, r: 12, t: 36, b: 30 },
        legend: { orientation: "h", y: -0.2, font: { size: 10 } },
        xaxis: { ticksuffix: " s", rangemode: "tozero" },
        paper_bgcolor: "rgba(0,0,0,0)",
        plot_bgcolor: "rgba(0,0,0,0)",
      },
      CONFIG,
    );
  }

  _curve(data) {
    if (!window.Plotly) return;
    const traces = ["a", "b"].map((s) => ({
      type: "scatter",
      mode: "lines",
      line: { shape: "hv", color: COLOURS[s] },
      name: `${s.toUpperCase()}: ${data[s].run.planner}`,
      x: data[s].curve.t,
      y: data[s].curve.queries,
      hovertemplate: "%{y} queries at %{x:.2f} s<extra></extra>",
    }));
    window.Plotly.react(
      this.el.curve,
      traces,
      {
        title: { text: "Stream queries made against planning seconds", x: 0.02, font: { size: 13 } },
        font: FONT,
        margin: { l: 50, r: 12, t: 36, b: 40 },
        legend: { orientation: "h", x: 1, xanchor: "right", y: 1.12 },
        xaxis: { title: { text: "seconds since the run started" }, rangemode: "tozero" },
        yaxis: { title: { text: "queries" }, rangemode: "tozero" },
        paper_bgcolor: "rgba(0,0,0,0)",
        plot_bgcolor: "rgba(0,0,0,0)",
      },
      CONFIG,
    );
  }

  _queries(data) {
    const streams = [...new Set([...Object.keys(data.a.queries), ...Object.keys(data.b.queries)])].sort();
    const cell = (q) =>
      q
        ? `<td class="num">${q.queries}</td><td class="num">${q.queries - q.failed}</td><td class="num bad-text">${q.failed}</td><td class="num">${seconds(q.failed_s)}</td>`
        : `<td class="num">0</td><td></td><td></td><td></td>`;
    const head = `<tr><th rowspan="2">stream</th><th colspan="4">A · ${escapeHtml(data.a.run.planner)}</th><th colspan="4">B · ${escapeHtml(data.b.run.planner)}</th></tr>
      <tr>${"<th>queries</th><th>ok</th><th>failed</th><th>failed s</th>".repeat(2)}</tr>`;
    const rows = streams.map((s) => `<tr data-stream="${escapeHtml(s)}"><td><code>${escapeHtml(s)}</code></td>${cell(data.a.queries[s])}${cell(data.b.queries[s])}</tr>`);
    this.el.queries.innerHTML = head + (rows.join("") || `<tr><td colspan="9" class="muted">No stream queries in either run.</td></tr>`);
  }

  _select(side, node) {
    this.views[side].selectedId = node ? node.id : null;
    this.views[side].requestDraw();
  }

  _hover(canvas, node, e) {
    const tip = this.el.tooltip;
    if (!node || !e) {
      tip.hidden = true;
      return;
    }
    const q = node.pred ? ` · Q ${seconds(node.pred.q)}` : "";
    const fail = node.parent !== null && node.stream !== null && !node.success ? " · failed" : "";
    tip.textContent = `#${node.id} ${node.label || shortLabel(node)}${fail}${q}`;
    tip.style.left = `${e.clientX + 12}px`;
    tip.style.top = `${e.clientY + 12}px`;
    tip.hidden = false;
  }

  /** For tests and the benchmark script: the nodes drawn, and where a node is on the page. */
  state() {
    return {
      key: this.key,
      ms: this.ms,
      nodes: { a: this.trees.a?.nodeCount ?? 0, b: this.trees.b?.nodeCount ?? 0 },
      marks: {
        a: [...this.views.a.marks.keys()],
        b: [...this.views.b.marks.keys()],
      },
      divergence: this.data?.divergence.kind ?? null,
    };
  }
}
