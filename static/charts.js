// Plotly charts of the selected run at the current step. Plotly is a classic script served by
// the app at /vendor/plotly.min.js (window.Plotly), loaded by app.js once a run is drawn; until
// then the charts say they are loading, and without it that they are unavailable.

import { QUERY_KIND_RGB, QUERY_KIND_TEXT, QUERY_KINDS } from "/generated/definitions.js";

const CONFIG = { displayModeBar: false, responsive: true };
const EMPTY = {
  showarrow: false,
  xref: "paper",
  yref: "paper",
  x: 0.5,
  y: 0.5,
  font: { color: "#6b7280" },
};
const FONT = { family: "system-ui, -apple-system, Segoe UI, sans-serif", size: 12, color: "#1f2937" };

function ready(el) {
  if (window.Plotly) {
    if (el.dataset.state !== "drawn") el.replaceChildren(); // drop the "select a run" text
    return true;
  }
  el.dataset.state = "unavailable";
  el.textContent = window.plotlyFailed
    ? "Charts unavailable: /vendor/plotly.min.js did not load."
    : "Loading the charts…";
  return false;
}

/**
 * Stacked bars of the queries per stream. ``counts`` is {stream: {ok, failed, reused}} (the
 * kinds of planner/figures.py: reused answers ran no sampler, and are not counted as queries);
 * ``note`` is a short text under the title (where the counts come from).
 */
export function drawQueries(el, counts, note = "", empty = "no stream queries yet") {
  if (!ready(el)) return;
  const streams = Object.keys(counts).sort();
  const kinds = QUERY_KINDS.filter((k) => k !== "reused" || streams.some((s) => counts[s].reused));
  const total = streams.reduce((a, s) => a + counts[s].ok + counts[s].failed, 0);
  const reused = streams.reduce((a, s) => a + (counts[s].reused ?? 0), 0);
  const data = kinds.map((kind) => ({
    type: "bar",
    name: kind === "reused" ? "reused (no sampler)" : kind,
    x: streams,
    y: streams.map((s) => counts[s][kind] ?? 0),
    marker: { color: `rgb(${QUERY_KIND_RGB[kind].join(",")})` },
    hovertemplate: `%{x}: %{y} ${kind}<extra>${QUERY_KIND_TEXT[kind]}</extra>`,
  }));
  const apart = reused ? `; ${reused} reused answers apart` : "";
  const small = note ? ` <span style="font-size:11px;color:#6b7280">${note}</span>` : "";
  const layout = {
    barmode: "stack",
    title: { text: `Queries per stream (${total}${apart})${small}`, x: 0.02, font: { size: 13 } },
    font: FONT,
    margin: { l: 44, r: 12, t: 36, b: 70 },
    legend: { orientation: "h", x: 1, xanchor: "right", y: 1.14 },
    xaxis: { tickangle: -30, automargin: true, visible: streams.length > 0 },
    yaxis: { title: { text: "queries" }, rangemode: "tozero", visible: streams.length > 0 },
    paper_bgcolor: "rgba(0,0,0,0)",
    plot_bgcolor: "rgba(0,0,0,0)",
    annotations: streams.length === 0 ? [{ ...EMPTY, text: empty }] : [],
  };
  window.Plotly.react(el, data, layout, CONFIG);
  el.dataset.state = "drawn";
  el.dataset.bars = String(streams.length);
  el.dataset.queries = String(total);
  el.dataset.reused = String(reused);
}

/**
 * One horizontal stacked bar of where the run's seconds went: the skeleton source's (top-k
 * planning, every batch), stream queries, the rest of the search, then executing the plan's
 * trajectories.
 */
export function drawTime(el, { topk, queries, planning, execution, live }) {
  if (!ready(el)) return;
  const search = Math.max(planning - topk - queries, 0);
  const parts = [
    ["skeletons", topk, "#6366f1"],
    ["stream queries", queries, "#f59e0b"],
    ["search overhead", search, "#94a3b8"],
    ["execution", execution ?? 0, "#0ea5e9"],
  ];
  const data = parts.map(([name, s, color]) => ({
    type: "bar",
    orientation: "h",
    name,
    x: [s],
    y: ["run"],
    marker: { color },
    hovertemplate: `${name}: %{x:.3f} s<extra></extra>`,
    text: [s > 0 ? `${s.toFixed(s < 10 ? 2 : 1)} s` : ""],
    textposition: "inside",
    insidetextanchor: "middle",
  }));
  const title =
    `Time: planning ${planning.toFixed(2)} s` +
    (execution !== null && execution !== undefined ? `, execution ${execution.toFixed(2)} s` : "") +
    (live ? " (so far)" : "");
  const layout = {
    barmode: "stack",
    title: { text: title, x: 0.02, font: { size: 13 } },
    font: FONT,
    margin: { l: 12, r: 12, t: 36, b: 20 },
    legend: { orientation: "h", y: -0.25, traceorder: "normal" },
    xaxis: { ticksuffix: " s", rangemode: "tozero" },
    yaxis: { visible: false },
    paper_bgcolor: "rgba(0,0,0,0)",
    plot_bgcolor: "rgba(0,0,0,0)",
  };
  window.Plotly.react(el, data, layout, CONFIG);
  el.dataset.state = "drawn";
}

export function clearChart(el, text) {
  if (window.Plotly && el.dataset.state === "drawn") window.Plotly.purge(el);
  el.dataset.state = "empty";
  el.innerHTML = `<p class="muted chart-empty">${text}</p>`;
}
