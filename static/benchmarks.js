// The benchmarks page (#benchmarks, #bench=ID): every benchmark of the store with its progress,
// a launch form, and one benchmark: progress bar and cancel, the paper's Fig. 2 scatter (one
// planner on each axis, a click opens the two runs in the compare view), the per-planner table
// and the paired improvement with its interval. The figures are planner.report.summarize's,
// the code of `tamp report` (GET /api/benchmarks/{id}). Below, the horizon curves (horizon.js).

import { STATUS } from "/generated/definitions.js";
import { ApiError, api } from "./api.js";
import { escapeHtml, seconds, when } from "./format.js";
import { HorizonPanel } from "./horizon.js";

const POLL_RUNNING_MS = 1000; // a running benchmark's page and the list while one runs
const POLL_IDLE_MS = 8000;
const MEASURES = ["planning", "execution", "total"];
const CONFIG = { displayModeBar: false, responsive: true };
const FONT = { family: "system-ui, -apple-system, Segoe UI, sans-serif", size: 12, color: "#1f2937" };
const SOLVED = "#2563eb";
const UNSOLVED = "#dc2626";
const MARKER_PX = 8; // the scatter's marker size
// Inside a marker plotly finds every point equally close (its distance stops at the marker's
// edge, plus about a pixel): a point this far from the cursor is under it.
const UNDER_PX = MARKER_PX / 2 + 1;

const $ = (id) => document.getElementById(id);

function pct(x) {
  return x === null || x === undefined ? "–" : `${(100 * x).toFixed(1)}%`;
}

/** A paired improvement as words: "41.9% less (95%: 30.1% to 52.0%, 20 seeds)". */
export function improvement(p) {
  if (!p || p.mean === null || p.mean === undefined) return `<span class="muted">– (${p?.n ?? 0} seeds)</span>`;
  const words = `${(100 * Math.abs(p.mean)).toFixed(1)}% ${p.mean >= 0 ? "less" : "more"}`;
  const cls = p.low > 0 ? "better" : p.high < 0 ? "worse" : "";
  const note = p.note ? ` <span class="interval-note" data-testid="interval-note" title="${escapeHtml(p.note)}">rough: only ${p.n} seed${p.n === 1 ? "" : "s"}</span>` : "";
  return `<span class="${cls}"><b>${words}</b></span> <span class="muted">(95%: ${pct(p.low)} to ${pct(p.high)}, ${p.n} seeds)</span>${note}`;
}

export class BenchPage {
  /** ``openTraining(benchId, planner)`` takes the user to the train form with those runs. */
  constructor({ openTraining }) {
    this.el = {
      form: $("bench-form"),
      scene: $("bench-scene"),
      planners: $("bench-planners"),
      trials: $("bench-trials"),
      seed: $("bench-seed"),
      budget: $("bench-budget"),
      workers: $("bench-workers"),
      modelField: $("bench-model-field"),
      model: $("bench-model"),
      error: $("bench-error"),
      list: $("bench-list"),
      total: $("bench-total"),
      listError: $("bench-list-error"),
      detail: $("bench-detail"),
    };
    this.openTraining = openTraining;
    this.visible = false;
    this.benches = [];
    this.current = null; // the id shown
    this.info = null; // its last GET
    this.plot = { measure: "total", x: null, y: null };
    this.listTimer = 0;
    this.detailTimer = 0;
    this.shownKey = "";
    this.ms = null; // milliseconds from asking for the benchmark to its page drawn
    this.el.form.addEventListener("submit", (e) => {
      e.preventDefault();
      this._launch();
    });
    this.el.planners.addEventListener("change", () => this._syncModel());
    this.el.scene.addEventListener("change", () => this._syncModel());
    this.horizon = new HorizonPanel($("horizon"), {
      open: (id) => {
        location.hash = `#bench=${encodeURIComponent(id)}`;
        this.el.detail.scrollIntoView({ block: "start" });
      },
    });
    this.el.list.addEventListener("click", (e) => {
      const row = e.target.closest("[data-bench-id]");
      if (row) location.hash = `#bench=${encodeURIComponent(row.dataset.benchId)}`;
    });
  }

  /** The scenes, planners and models of the launch form (the run form's own lists). */
  setChoices(scenes, planners, models) {
    this.scenes = scenes;
    this.models = models;
    this.el.scene.innerHTML = scenes
      .map((s) => `<option value="${escapeHtml(s.name)}">${escapeHtml(s.name)}</option>`)
      .join("");
    const checked = new Set(["baseline", "learned"]);
    this.el.planners.insertAdjacentHTML(
      "beforeend",
      planners
        .map(
          (p) => `<label class="check"><input type="checkbox" name="planner" value="${escapeHtml(p)}"
            data-testid="bench-planner-${escapeHtml(p)}" ${checked.has(p) ? "checked" : ""}/> ${escapeHtml(p)}</label>`,
        )
        .join(""),
    );
    this._syncModel();
  }

  _planners() {
    return [...this.el.planners.querySelectorAll("input:checked")].map((i) => i.value);
  }

  _syncModel() {
    const learned = this._planners().some((p) => p === "learned" || p === "paper");
    this.el.modelField.hidden = !learned;
    const scene = this.scenes?.find((s) => s.name === this.el.scene.value);
    const models = (this.models ?? []).filter((m) => !scene || !m.domain || m.domain === scene.domain);
    const chosen = this.el.model.value;
    this.el.model.innerHTML =
      `<option value="">the domain's default (or per-stream priors)</option>` +
      models.map((m) => `<option value="${escapeHtml(m.name)}">${escapeHtml(m.name)}</option>`).join("");
    if (models.some((m) => m.name === chosen)) this.el.model.value = chosen;
  }

  setModels(models) {
    this.models = models;
    this._syncModel();
  }

  async _launch() {
    this.el.error.hidden = true;
    const number = (input, fallback) => (input.value === "" ? fallback : Number(input.value));
    const body = {
      scene: this.el.scene.value,
      planners: this._planners(),
      trials: number(this.el.trials, 4),
      seed_start: number(this.el.seed, 1000),
      budget_s: number(this.el.budget, 60),
      workers: number(this.el.workers, 2),
    };
    if (!this.el.modelField.hidden && this.el.model.value) body.model = this.el.model.value;
    const submit = this.el.form.querySelector("button[type=submit]");
    submit.disabled = true;
    try {
      const bench = await api("/api/benchmarks", { method: "POST", body });
      location.hash = `#bench=${encodeURIComponent(bench.id)}`;
      this.refreshList();
    } catch (err) {
      this.el.error.textContent = err instanceof ApiError ? err.message : String(err);
      this.el.error.hidden = false;
    } finally {
      submit.disabled = false;
    }
  }

  /** The page is shown (``id``: one benchmark) or hidden (``visible`` false). */
  show(visible, id = null) {
    this.visible = visible;
    clearTimeout(this.listTimer);
    clearTimeout(this.detailTimer);
    if (!visible) return;
    this.refreshList();
    if (id !== this.current) {
      this.current = id;
      this.info = null;
      this.shownKey = "";
      this.plot = { measure: this.plot.measure, x: null, y: null };
      this.el.detail.innerHTML = id
        ? `<section class="card"><p class="muted">Loading benchmark ${escapeHtml(id.slice(0, 8))}…</p></section>`
        : `<section class="card"><p class="muted">Select a benchmark, or launch one.</p></section>`;
    }
    if (id) this.refreshDetail();
  }

  async refreshList() {
    clearTimeout(this.listTimer);
    try {
      this.benches = await api("/api/benchmarks");
      this.el.listError.hidden = true;
      this._renderList();
      if (this.visible) this.horizon.follow(this.benches);
    } catch (err) {
      this.el.listError.textContent = `Cannot load benchmarks: ${err.message}`;
      this.el.listError.hidden = false;
    }
    if (!this.visible) return;
    this._followProgress();
    const running = this.benches.some((b) => b.status === STATUS.RUNNING);
    this.listTimer = setTimeout(() => this.refreshList(), running ? POLL_RUNNING_MS : POLL_IDLE_MS);
  }

  _renderList() {
    this.el.total.textContent = `(${this.benches.length})`;
    if (this.benches.length === 0) {
      this.el.list.innerHTML = `<tr><td class="muted">No benchmarks yet: launch one above, or run <code>tamp bench</code>.</td></tr>`;
      return;
    }
    this.el.list.innerHTML =
      `<tr><th>scene</th><th>planners</th><th>seeds</th><th>progress</th><th>state</th></tr>` +
      this.benches
        .map(
          (b) => `<tr data-bench-id="${escapeHtml(b.id)}" data-testid="bench-row" data-status="${escapeHtml(b.status)}"
              class="${b.id === this.current ? "selected" : ""}" tabindex="0" title="${escapeHtml(b.id)} · ${escapeHtml(when(b.created_at))}">
            <td>${escapeHtml(b.scene)}</td>
            <td>${b.planners.map(escapeHtml).join(", ")}</td>
            <td class="num">${b.seeds}</td>
            <td><progress max="${b.total}" value="${b.done}"></progress> <span class="muted">${b.done}/${b.total}</span></td>
            <td><span class="badge ${escapeHtml(b.status)}">${escapeHtml(b.status)}</span></td>
          </tr>`,
        )
        .join("");
  }

  /** The shown benchmark's progress from the list; its page again once it stopped. */
  _followProgress() {
    const listed = this.benches.find((b) => b.id === this.current);
    const info = this.info;
    if (!listed || !info || info.id !== listed.id) return;
    if (listed.status !== info.status) {
      this.refreshDetail();
      return;
    }
    const bar = this.el.detail.querySelector("[data-testid=bench-progress]");
    if (bar && listed.done > Number(bar.value)) {
      bar.value = listed.done;
      this.el.detail.querySelector("[data-testid=bench-progress-text]").textContent = `${listed.done} / ${listed.total} trials`;
    }
  }

  async refreshDetail() {
    clearTimeout(this.detailTimer);
    const id = this.current;
    if (!id) return;
    const t0 = performance.now();
    let info;
    try {
      info = await api(`/api/benchmarks/${encodeURIComponent(id)}`);
    } catch (err) {
      if (id !== this.current) return;
      this.el.detail.innerHTML = `<section class="card"><p class="error-text" data-testid="bench-detail-error">Benchmark ${escapeHtml(id)}: ${escapeHtml(err.message)}</p></section>`;
      return;
    }
    if (id !== this.current || !this.visible) return;
    this.info = info;
    this._renderDetail(info);
    this.ms = performance.now() - t0;
    document.body.dataset.bench = `${info.id}:${info.done}`;
    if (info.status === STATUS.RUNNING) {
      // A large benchmark's summary costs the server seconds (the bootstrap of tamp report)
      // each time a trial finished: ask for it at most a tenth of the time; the progress
      // bar follows the cheap list meanwhile (refreshList).
      const wait = Math.max(POLL_RUNNING_MS, 10 * this.ms);
      this.detailTimer = setTimeout(() => this.refreshDetail(), wait);
    }
  }

  _renderDetail(info) {
    // The head (its buttons) is redrawn only when the state changes, so that a click on Cancel
    // is not lost to a redraw; the progress in it is updated in place.
    const live = info.status === STATUS.RUNNING;
    const resumable = (info.status === STATUS.CANCELLED || info.status === STATUS.INTERRUPTED) && info.done < info.total;
    const headKey = JSON.stringify([info.id, info.status, info.runner, resumable, info.message]);
    const bodyKey = JSON.stringify([info.id, info.status, info.done]);
    if (`${headKey}${bodyKey}` === this.shownKey) return;
    const first = this.shownKey === "" || !this.shownKey.startsWith(`[${JSON.stringify(info.id)}`);
    const headChanged = !this.shownKey.startsWith(headKey) || !$("bench-head-slot");
    this.shownKey = `${headKey}${bodyKey}`;
    const planners = info.planners;
    if (this.plot.x === null || !planners.includes(this.plot.x)) this.plot.x = planners[0];
    if (this.plot.y === null || !planners.includes(this.plot.y)) this.plot.y = planners[1] ?? planners[0];
    const perPlanner = planners
      .map((p) => `${escapeHtml(p)} ${info.progress[p]?.done ?? 0} done, ${info.progress[p]?.solved ?? 0} solved`)
      .join(" · ");
    const head = `<section class="card" data-testid="bench-head">
      <div class="run-header">
        <span class="run-name" title="${escapeHtml(info.id)}">Benchmark ${escapeHtml(info.id.slice(0, 8))}</span>
        <span>${escapeHtml(info.scene)} · ${planners.map(escapeHtml).join(" vs ")} · seeds ${info.seed_first}–${info.seed_last} · ${seconds(info.budget_s)} budget${info.model ? ` · model ${escapeHtml(info.model)}` : ""}</span>
        <span class="badge ${escapeHtml(info.status)}" data-testid="bench-status">${escapeHtml(info.status)}</span>
        ${live && info.runner === "dashboard" ? `<button type="button" class="danger" data-testid="bench-cancel">Cancel</button>` : ""}
        ${resumable ? `<button type="button" data-testid="bench-resume">Resume the ${info.total - info.done} missing trials</button>` : ""}
      </div>
      <div class="progress-line">
        <progress data-testid="bench-progress" max="${info.total}" value="${info.done}"></progress>
        <span data-testid="bench-progress-text">${info.done} / ${info.total} trials</span>
        <span class="muted" data-testid="bench-progress-planners">${perPlanner}</span>
      </div>
      ${info.message ? `<p class="muted">${escapeHtml(info.message)}</p>` : ""}
      ${live && info.runner === "elsewhere" ? `<p class="muted">Run by another process (<code>tamp bench</code>): it cannot be cancelled from here.</p>` : ""}
      <div id="bench-action-error" class="error" role="alert" hidden></div>
    </section>`;
    const summary = info.summary;
    const controls = `<div class="plot-controls">
        <label>Seconds <select data-testid="scatter-measure" data-plot="measure">${MEASURES.map((m) => `<option ${m === this.plot.measure ? "selected" : ""}>${m}</option>`).join("")}</select></label>
        <label>x axis <select data-testid="scatter-x" data-plot="x">${planners.map((p) => `<option ${p === this.plot.x ? "selected" : ""}>${escapeHtml(p)}</option>`).join("")}</select></label>
        <label>y axis <select data-testid="scatter-y" data-plot="y">${planners.map((p) => `<option ${p === this.plot.y ? "selected" : ""}>${escapeHtml(p)}</option>`).join("")}</select></label>
        <span class="hint">Each point a seed; below the diagonal the y planner was faster. A hover names the seeds under the cursor; a click opens the nearest one's two runs side by side.</span>
      </div>`;
    const train = planners
      .map(
        (p) => `<button type="button" data-train="${escapeHtml(p)}" data-testid="bench-train-${escapeHtml(p)}"
          ${(info.progress[p]?.done ?? 0) < 2 ? "disabled" : ""}>Train a model from the ${escapeHtml(p)} runs</button>`,
      )
      .join(" ");
    if (first || !$("bench-head-slot")) {
      this.el.detail.innerHTML = `<div id="bench-head-slot"></div><div id="bench-body-slot" class="main"></div>`;
    }
    if (headChanged) {
      $("bench-head-slot").innerHTML = head;
      this._bindHead(info);
    } else {
      const bar = this.el.detail.querySelector("[data-testid=bench-progress]");
      bar.value = info.done;
      this.el.detail.querySelector("[data-testid=bench-progress-text]").textContent = `${info.done} / ${info.total} trials`;
      this.el.detail.querySelector("[data-testid=bench-progress-planners]").textContent = perPlanner;
    }
    $("bench-body-slot").innerHTML = `
      <section class="card">
        ${controls}
        <div id="bench-scatter" data-testid="bench-scatter" class="chart scatter"></div>
      </section>
      <section class="card">
        <h2>Per planner <span class="muted">(tamp report; seconds over solved trials)</span></h2>
        <table class="grid" data-testid="bench-table">${this._plannerTable(summary)}</table>
        <h2>Paired improvement over ${escapeHtml(summary.reference)} <span class="muted">(1 − mean ours / mean reference, unsolved counted at the budget; bootstrap 95% interval)</span></h2>
        <table class="grid" data-testid="bench-paired">${this._pairedTable(summary)}</table>
        <p class="train-actions">${train}</p>
      </section>
      <section class="card">
        <details ${summary.trials.length <= 50 ? "open" : ""}><summary>Trials (${summary.trials.length})</summary>
          <table class="grid" data-testid="bench-trials-table">${this._trialsTable(summary)}</table>
        </details>
      </section>`;
    this._bindBody(info);
    this._scatter(info);
    if (first) this.el.detail.scrollTop = 0;
  }

  _plannerTable(summary) {
    const stat = (s) => `${seconds(s?.mean)} <span class="muted">/ ${seconds(s?.median)}</span>`;
    const rows = Object.entries(summary.planners).map(
      ([p, s]) => `<tr data-planner="${escapeHtml(p)}"><td><b>${escapeHtml(p)}</b></td>
        <td class="num">${s.trials}</td><td class="num">${s.solved} (${pct(s.solved_fraction)})</td>
        <td class="num">${stat(s.planning_s)}</td><td class="num">${stat(s.execution_s)}</td>
        <td class="num">${stat(s.total_s)}</td><td class="num">${seconds(s.total_s_censored?.mean)}</td>
        <td class="num">${seconds(s.time_split?.queries_s)}</td><td class="num">${seconds(s.time_split?.search_s)} <span class="muted">/ ${seconds(s.time_split?.search_cpu_s)}</span></td></tr>`,
    );
    return `<tr><th>planner</th><th>trials</th><th>solved</th><th>planning mean / median</th><th>execution</th><th>total</th><th>total, unsolved at budget</th><th>queries s (mean)</th><th title="the search's own seconds outside the stream queries: wall, then its thread's CPU">search s, wall / CPU (mean)</th></tr>${rows.join("")}`;
  }

  _pairedTable(summary) {
    const rows = Object.entries(summary.paired).map(
      ([p, e]) => `<tr data-planner="${escapeHtml(p)}"><td><b>${escapeHtml(p)}</b></td>
        ${MEASURES.map((m) => `<td data-measure="${m}">${improvement(e[`${m}_censored`])}</td>`).join("")}
        <td class="num">${e.both_solved} / ${e.seeds}</td></tr>`,
    );
    if (rows.length === 0) return `<tr><td class="muted">One planner only: nothing to pair.</td></tr>`;
    return `<tr><th>planner</th><th>planning</th><th>execution (both solved)</th><th>total</th><th>seeds both solved</th></tr>${rows.join("")}`;
  }

  _trialsTable(summary) {
    const planners = Object.keys(summary.planners);
    const cell = (t) =>
      t && t.status
        ? `<td><span class="badge ${escapeHtml(t.status)}">${escapeHtml(t.status)}</span> ${seconds(t.planning)} + ${seconds(t.execution)}</td>`
        : `<td class="muted">–</td>`;
    const rows = summary.trials.map((row) => {
      const ids = planners.map((p) => row[p]?.run_id).filter(Boolean);
      const link = ids.length >= 2 ? `<a href="#compare=${ids.slice(0, 2).map(encodeURIComponent).join(",")}">compare</a>` : "";
      return `<tr data-seed="${row.seed}"><td class="num">${row.seed}</td>${planners.map((p) => cell(row[p])).join("")}<td>${link}</td></tr>`;
    });
    return `<tr><th>seed</th>${planners.map((p) => `<th>${escapeHtml(p)} planning + execution</th>`).join("")}<th></th></tr>${rows.join("")}`;
  }

  _bindBody(info) {
    const detail = this.el.detail;
    detail.querySelectorAll("[data-plot]").forEach((select) =>
      select.addEventListener("change", () => {
        this.plot[select.dataset.plot] = select.value;
        this._scatter(this.info);
      }),
    );
    detail.querySelectorAll("[data-train]").forEach((b) =>
      b.addEventListener("click", () => this.openTraining(info.id, b.dataset.train)),
    );
  }

  _bindHead(info) {
    const detail = this.el.detail;
    const error = (err) => {
      const box = $("bench-action-error");
      box.textContent = err.message;
      box.hidden = false;
    };
    detail.querySelector("[data-testid=bench-cancel]")?.addEventListener("click", async (e) => {
      e.target.disabled = true;
      try {
        await api(`/api/benchmarks/${encodeURIComponent(info.id)}`, { method: "DELETE" });
      } catch (err) {
        error(err);
      }
      this.refreshDetail();
      this.refreshList();
    });
    detail.querySelector("[data-testid=bench-resume]")?.addEventListener("click", async (e) => {
      e.target.disabled = true;
      try {
        await api(`/api/benchmarks/${encodeURIComponent(info.id)}/resume`, { method: "POST", body: {} });
      } catch (err) {
        error(err);
      }
      this.refreshDetail();
      this.refreshList();
    });
  }

  /** The points of the scatter: seeds both planners ran, each with both run ids. */
  points(info = this.info) {
    const { measure, x, y } = this.plot;
    const out = [];
    for (const row of info?.summary.trials ?? []) {
      const a = row[x];
      const b = row[y];
      if (!a?.status || !b?.status || a[measure] === undefined || b[measure] === undefined) continue;
      out.push({ seed: row.seed, x: a[measure], y: b[measure], a: a.run_id, b: b.run_id, solved: a.status === STATUS.SOLVED && b.status === STATUS.SOLVED });
    }
    return out;
  }

  _scatter(info) {
    const box = $("bench-scatter");
    if (!box || !window.Plotly) return;
    const { measure, x, y } = this.plot;
    const pts = this.points(info);
    const top = Math.max(1e-3, ...pts.map((p) => Math.max(p.x, p.y))) * 1.05;
    this.drawn = [true, false].map((solved) => pts.filter((p) => p.solved === solved)); // by curve
    const trace = (solved) => {
      const mine = this.drawn[solved ? 0 : 1];
      return {
        type: "scatter",
        mode: "markers",
        name: solved ? "both solved" : "one unsolved (at the budget)",
        x: mine.map((p) => p.x),
        y: mine.map((p) => p.y),
        customdata: mine.map((p) => [p.seed, p.a, p.b]),
        marker: { color: solved ? SOLVED : UNSOLVED, size: MARKER_PX, opacity: 0.75, symbol: solved ? "circle" : "x" },
        hovertemplate: `seed %{customdata[0]}<br>${escapeHtml(x)} %{x:.2f} s<br>${escapeHtml(y)} %{y:.2f} s<extra></extra>`,
      };
    };
    const layout = {
      title: { text: `${measure} seconds: ${escapeHtml(y)} against ${escapeHtml(x)} (${pts.length} seeds)`, x: 0.02, font: { size: 13 } },
      font: FONT,
      margin: { l: 60, r: 16, t: 40, b: 50 },
      xaxis: { title: { text: `${x} ${measure} s` }, range: [0, top], zeroline: false },
      yaxis: { title: { text: `${y} ${measure} s` }, range: [0, top], zeroline: false },
      shapes: [{ type: "line", x0: 0, y0: 0, x1: top, y1: top, line: { color: "#9ca3af", dash: "dot", width: 1 } }],
      legend: { orientation: "h", x: 1, xanchor: "right", y: 1.1 },
      hovermode: "closest",
      paper_bgcolor: "rgba(0,0,0,0)",
      plot_bgcolor: "rgba(0,0,0,0)",
    };
    window.Plotly.react(box, [trace(true), trace(false)], layout, CONFIG).then(() => {
      box.dataset.points = String(pts.length);
      box.dataset.measure = measure;
    });
    if (!box.dataset.bound) {
      box.dataset.bound = "1";
      // Where markers overlap, plotly's closest hover names one seed of those under the cursor
      // (the last drawn, not the nearest): there it names every seed under the cursor instead,
      // the nearest first, and so a click opens the nearest (plotly_click gets that order).
      box.on("plotly_beforehover", (event) => {
        if (typeof event?.clientX !== "number") return undefined;
        const under = this.pointsAt(event.clientX, event.clientY);
        if (under.length < 2) return undefined; // plotly's own hover: the nearest point
        window.Plotly.Fx.hover(box, under.map(({ curve, index }) => ({ curveNumber: curve, pointNumber: index })));
        return false;
      });
      box.on("plotly_click", (event) => {
        const point = event.points?.[0];
        if (!point) return;
        const [, a, b] = point.customdata;
        if (a && b) location.hash = `#compare=${encodeURIComponent(a)},${encodeURIComponent(b)}`;
      });
    }
  }

  /** Where the scatter draws seed ``seed`` on the page (client px), or null; for tests. */
  pointPosition(seed) {
    const box = $("bench-scatter");
    const p = this.points().find((q) => q.seed === seed);
    if (!box || !p || !box._fullLayout) return null;
    return this._toPage(box)(p);
  }

  /** A function from a scatter point to where it is drawn on the page (client px). */
  _toPage(box) {
    const full = box._fullLayout;
    const rect = box.getBoundingClientRect();
    return (p) => ({
      x: rect.left + full._size.l + full.xaxis.l2p(p.x),
      y: rect.top + full._size.t + full.yaxis.l2p(p.y),
    });
  }

  /** The drawn points under the page point (x, y), nearest first (then by seed), each as
   * {seed, curve, index, d}: its trace, its index in it and its distance in pixels. */
  pointsAt(x, y) {
    const box = $("bench-scatter");
    if (!box?._fullLayout || !this.drawn) return [];
    const toPage = this._toPage(box);
    const out = [];
    this.drawn.forEach((mine, curve) =>
      mine.forEach((p, index) => {
        const at = toPage(p);
        const d = Math.hypot(at.x - x, at.y - y);
        if (d <= UNDER_PX) out.push({ seed: p.seed, curve, index, d });
      }),
    );
    return out.sort((a, b) => a.d - b.d || a.seed - b.seed);
  }
}


