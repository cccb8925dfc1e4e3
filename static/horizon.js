// The horizon panel of the benchmarks page: the curves `tamp horizon` draws, for every series of
// the store (GET /api/benchmarks/horizon: benchmarks of one domain with the same settings over
// different scenes). A selector of the series, and two plotly charts side by side (mean planning
// and total seconds against the objects in the goal), one line per planner with its 95%
// interval as error bars; a click on a point opens its benchmark.

import { MIN_INTERVAL_SEEDS, STATUS } from "/generated/definitions.js";
import { api } from "./api.js";
import { escapeHtml } from "./format.js";

const CONFIG = { displayModeBar: false, responsive: true };
const FONT = { family: "system-ui, -apple-system, Segoe UI, sans-serif", size: 12, color: "#1f2937" };
const COLORS = ["#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860"]; // planner/horizon.py's
const NAMED_COLORS = { baseline: COLORS[0], paper: COLORS[1], learned: COLORS[2] };

/** A colour per planner, as planner/horizon.py's planner_colors: the three keep theirs in every
 * series, other planners take the remaining colours in turn. */
function plannerColors(planners) {
  const named = Object.values(NAMED_COLORS);
  const rest = COLORS.filter((c) => !named.includes(c));
  const others = [...new Set(planners)].filter((p) => !(p in NAMED_COLORS));
  return Object.fromEntries(planners.map((p) => [p, NAMED_COLORS[p] ?? rest[others.indexOf(p) % rest.length]]));
}
const CHARTS = [
  ["planning", "horizon-planning", "Planning s"],
  ["total", "horizon-total", "Total s (planning + execution)"],
];
const MIN_WAIT_MS = 1000;

export class HorizonPanel {
  /** ``root`` is the panel's card; ``open(benchId)`` shows a benchmark. */
  constructor(root, { open }) {
    this.root = root;
    this.body = root.querySelector("[data-horizon-body]");
    this.open = open;
    this.series = null; // the last answer
    this.key = null; // the series shown
    this.listKey = null; // the benchmarks (id, status, done) the last answer was asked for
    this.drawnKey = "";
    this.loading = false;
    this.askedAt = -Infinity;
    this.ms = 0; // how long the last answer took
  }

  /**
   * The benchmarks list was read: ask for the series again when a benchmark came, went, changed
   * state or finished trials, at most every 10 times as long as the last answer took (summaries
   * of large benchmarks cost the server seconds; unchanged ones are kept there).
   */
  follow(benches) {
    const key = benches.map((b) => `${b.id}:${b.status}:${b.done}`).join(" ");
    if (key === this.listKey || this.loading) return;
    if (performance.now() - this.askedAt < Math.max(MIN_WAIT_MS, 10 * this.ms)) return;
    this.refresh(key);
  }

  async refresh(listKey = this.listKey) {
    this.loading = true;
    this.askedAt = performance.now();
    try {
      this.series = await api("/api/benchmarks/horizon");
      this.ms = performance.now() - this.askedAt;
      this.listKey = listKey;
      this.render();
    } catch (err) {
      this.body.innerHTML = `<p class="error-text" data-testid="horizon-error">Cannot load the horizon curves: ${escapeHtml(err.message)}</p>`;
      this.drawnKey = "";
    } finally {
      this.loading = false;
    }
  }

  render() {
    const series = this.series ?? [];
    this.root.dataset.series = String(series.length);
    if (series.length === 0) {
      this.key = null;
      this.drawnKey = "";
      this.body.innerHTML = `<p class="muted" data-testid="horizon-empty">No series yet: <code>tamp horizon --scenes A,B,…</code> runs one (a benchmark per scene, same settings).</p>`;
      return;
    }
    if (!series.some((s) => s.key === this.key)) this.key = series[0].key;
    const options = series.map((s) => `<option value="${escapeHtml(s.key)}">${escapeHtml(s.label)}</option>`).join("");
    let select = this.body.querySelector("[data-testid=horizon-series]");
    if (!select || select.dataset.options !== options) {
      this.body.innerHTML = `<div class="plot-controls">
          <label>Series <select data-testid="horizon-series"></select></label>
          <span class="hint" data-testid="horizon-scenes"></span>
        </div>
        <div class="horizon-charts">
          ${CHARTS.map(([, id]) => `<div id="${id}" data-testid="${id}" class="chart"></div>`).join("")}
        </div>`;
      select = this.body.querySelector("[data-testid=horizon-series]");
      select.innerHTML = options;
      select.dataset.options = options;
      select.addEventListener("change", () => {
        this.key = select.value;
        this.draw();
      });
      this.drawnKey = "";
    }
    select.value = this.key;
    this.draw();
  }

  /** The selected series, or null. */
  shown() {
    return (this.series ?? []).find((s) => s.key === this.key) ?? null;
  }

  draw() {
    const series = this.shown();
    if (!series) return;
    if (!window.Plotly) {
      for (const [, id] of CHARTS) this.body.querySelector(`#${id}`).textContent = "Charts unavailable: /vendor/plotly.min.js did not load.";
      return;
    }
    const drawnKey = JSON.stringify(series);
    if (drawnKey === this.drawnKey) return;
    this.drawnKey = drawnKey;
    const scenes = series.benchmarks
      .map((b) => `${escapeHtml(b.scene)} (${b.objects})${b.status === STATUS.DONE ? "" : ` ${escapeHtml(b.status)}: ${b.done}/${b.total} trials`}`)
      .join(" · ");
    this.body.querySelector("[data-testid=horizon-scenes]").innerHTML =
      `${scenes}. Means over the seeds every planner finished (unsolved at the budget), 95% intervals; a click opens the benchmark.` +
      (series.trials < MIN_INTERVAL_SEEDS
        ? ` <b data-testid="horizon-few-seeds">Only ${series.trials} seed${series.trials === 1 ? "" : "s"} a scene: intervals over fewer than ${MIN_INTERVAL_SEEDS} are rough.</b>`
        : "");
    const xs = [...new Set(series.points.map((p) => p.objects))].sort((a, b) => a - b);
    const span = xs.length > 1 ? xs[xs.length - 1] - xs[0] : 1;
    const n = series.planners.length;
    CHARTS.forEach(([measure, id, title], c) => {
      const el = this.body.querySelector(`#${id}`);
      const colors = plannerColors(series.planners);
      const traces = series.planners.map((planner, i) => {
        const mine = series.points.filter((p) => p.planner === planner);
        const shift = (i - (n - 1) / 2) * 0.012 * span; // side by side, so the bars do not hide
        return {
          type: "scatter",
          mode: "lines+markers",
          name: planner,
          legendgroup: planner,
          x: mine.map((p) => p.objects + shift),
          y: mine.map((p) => p[measure][0]),
          error_y: {
            type: "data",
            symmetric: false,
            array: mine.map((p) => p[measure][2] - p[measure][0]),
            arrayminus: mine.map((p) => p[measure][0] - p[measure][1]),
            thickness: 1.5,
            width: 4,
          },
          customdata: mine.map((p) => [p.scene, p.solved, p.seeds, p.bench_id, p[measure][1], p[measure][2], p.objects]),
          hovertemplate:
            `<b>${escapeHtml(planner)}</b> · %{customdata[0]} (objects: %{customdata[6]})<br>` +
            `%{y:.2f} s (95%: %{customdata[4]:.2f} to %{customdata[5]:.2f})<br>` +
            `solved %{customdata[1]} / %{customdata[2]} seeds<br>benchmark %{customdata[3]}<extra></extra>`,
          line: { color: colors[planner], width: 2 },
          marker: { color: colors[planner], size: 8 },
        };
      });
      if (measure === "planning") {
        // Planning's part spent on skeletons (the skeleton source's seconds, every batch), dashed.
        for (const planner of series.planners) {
          const mine = series.points.filter((p) => p.planner === planner && p.skeleton);
          if (mine.length === 0) continue;
          traces.push({
            type: "scatter",
            mode: "lines",
            name: `${planner}: skeletons`,
            legendgroup: planner,
            showlegend: false,
            x: mine.map((p) => p.objects),
            y: mine.map((p) => p.skeleton[0]),
            hovertemplate: `<b>${escapeHtml(planner)}</b>: %{y:.2f} s of skeletons<extra></extra>`,
            line: { color: colors[planner], width: 1.5, dash: "dash" },
          });
        }
      }
      const layout = {
        title: { text: title, x: 0.02, font: { size: 13 } },
        font: FONT,
        margin: { l: 56, r: 12, t: 40, b: 48 },
        xaxis: { title: { text: "objects in the goal" }, tickvals: xs, zeroline: false },
        yaxis: { title: { text: "seconds" }, rangemode: "tozero" },
        showlegend: c === 0, // the colours are the same in both
        legend: { orientation: "h", x: 1, xanchor: "right", y: 1.16 },
        hovermode: "closest",
        paper_bgcolor: "rgba(0,0,0,0)",
        plot_bgcolor: "rgba(0,0,0,0)",
      };
      window.Plotly.react(el, traces, layout, CONFIG);
      this._bind(el);
      el.dataset.traces = String(traces.length);
      el.dataset.points = String(series.points.length);
      el.dataset.state = "drawn";
    });
    this.root.dataset.shown = series.key;
  }

  _bind(el) {
    if (el.dataset.bound) return;
    el.dataset.bound = "1";
    el.on("plotly_click", (event) => {
      const id = event.points?.[0]?.customdata?.[3];
      if (id) this.open(id);
    });
  }
}
