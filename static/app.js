// The dashboard page: launch runs, list them, replay and watch one run's search; and, on pages
// of their own (the hash says which), two runs compared (compare.js), benchmarks
// (benchmarks.js) and models with their training (models.js).
//
// It talks only to the REST API and the websocket of docs/dashboard.md. The selected run has
// one owner, ``app.run`` (made afresh by ``resetRunView`` on every switch of run): its events
// in a Replay (tree.js), the cursor, the selection, the search, the 3D view's ghost clicks
// seen. A run's stored events are read in bulk (pages of GET /api/runs/{id}/events); a run
// still going then follows over the websocket from its last stored event. The step slider
// moves the cursor and the canvas (treeview.js) redraws at the next animation frame.
//
// What the figures mean (query kinds, the Q scale) and every name the page compares with
// (event types, statuses) are planner/figures.py's, imported from /generated/definitions.js:
// EVENT.NODE_ADDED, STATUS.QUEUED, never a literal (tests/app/test_reads.py checks).

import { EVENT, LIVE_STATUSES, RUN_STATUSES, STATUS, STATUS_TEXT } from "/generated/definitions.js";
import { ApiError, api, streamUrl } from "./api.js";
import { BenchPage } from "./benchmarks.js";
import { clearChart, drawQueries, drawTime } from "./charts.js";
import { CompareView } from "./compare.js";
import { count, escapeHtml, num, seconds, value, when } from "./format.js";
import { ModelsPage } from "./models.js";
import { Replay } from "./tree.js";
import { TreeView, nodeText, qGradient, qRgbAt, shortLabel } from "./treeview.js";

const LIVE = new Set(LIVE_STATUSES);
const POLL_LIVE_MS = 1500; // runs list refresh while some run is queued or running
const POLL_IDLE_MS = 8000; // otherwise
const VIEWER_DEBOUNCE_MS = 200;
const PICKED_POLL_MS = 1500; // how often the page asks which ghost was clicked in the 3D view
const CHART_DELAY_MS = 250; // charts follow the step at most this often
const RECONNECT_MS = [1000, 2000, 5000, 10000]; // waits before reconnecting a dropped stream
const PAGE = 50; // runs per page of the list
const EVENT_PAGE = 5000; // events per page of a stored run (the route's most)
const PAGES_AT_ONCE = 4; // pages of a stored run asked for at once (the server reads 4 at once)
const SEARCH_MOST = 5000; // matches of a search kept
const SIDE_BY_SIDE_PX = 1500; // from this width the 3D view stands beside the tree by default
const PLAY_ICON = '<svg viewBox="0 0 16 16" aria-hidden="true"><path d="M4 2.5v11l9-5.5z"/></svg>';
const PAUSE_ICON = '<svg viewBox="0 0 16 16" aria-hidden="true"><path d="M4 3h3v10H4zM9 3h3v10H9z"/></svg>';

const $ = (id) => document.getElementById(id);
let plotlyAsked = false; // loadPlotly was called

const el = {
  health: $("health"),
  form: $("launch-form"),
  scene: $("launch-scene"),
  sceneDescription: $("scene-description"),
  planner: $("launch-planner"),
  seed: $("launch-seed"),
  budget: $("launch-budget"),
  maxQueries: $("launch-max-queries"),
  modelField: $("launch-model-field"),
  model: $("launch-model"),
  submit: $("launch-submit"),
  launchError: $("launch-error"),
  filter: $("status-filter"),
  runs: $("runs-list"),
  runsTotal: $("runs-total"),
  runsError: $("runs-error"),
  runsMore: $("runs-more"),
  reports: $("reports"),
  reportsList: $("reports-list"),
  header: $("run-header"),
  canvas: $("tree-canvas"),
  treeEmpty: $("tree-empty"),
  skeletonNote: $("skeleton-note"),
  tooltip: $("tree-tooltip"),
  nodeCount: $("node-count"),
  fit: $("btn-fit"),
  searchInput: $("tree-search"),
  searchCount: $("search-count"),
  searchPrev: $("search-prev"),
  searchNext: $("search-next"),
  qLegend: $("q-legend"),
  qLo: $("q-lo"),
  qHi: $("q-hi"),
  qRamp: $("q-ramp"),
  qMark: $("q-mark"),
  qSelected: $("q-selected"),
  inspectorTitle: $("inspector-title"),
  inspectorHint: $("inspector-hint"),
  inspectorBody: $("inspector-body"),
  first: $("btn-first"),
  back: $("btn-step-back"),
  play: $("btn-play"),
  forward: $("btn-step-forward"),
  last: $("btn-last"),
  slider: $("step-slider"),
  speed: $("play-speed"),
  stepLabel: $("step-label"),
  stepEvent: $("step-event"),
  liveBadge: $("live-badge"),
  chartQueries: $("chart-queries"),
  chartTime: $("chart-time"),
  viewerFrame: $("viewer-frame"),
  viewerNote: $("viewer-note"),
  viewerPicked: $("viewer-picked"),
  layoutToggle: $("btn-layout"),
  pages: document.querySelectorAll("[data-page]"),
};

const app = {
  health: null,
  scenes: [],
  models: [],
  runs: [],
  limit: PAGE,
  replay: new Replay(),
  run: null, // the selected run's state (newRunState); id null for loaded events
  follow: true, // the cursor stays on the newest event as events arrive
  playing: false,
  selectedId: null,
  pending: [], // events received and not yet appended
  flushQueued: false,
  search: { text: "", matches: [], at: -1, size: -1 },
};

const view = new TreeView(el.canvas, {
  onSelect: (node) => {
    app.selectedId = node ? node.id : null;
    renderInspector();
    renderLegend();
    scheduleViewer();
  },
  onHover: showTooltip,
  onViewChange: () => renderLegend(),
});
view.setTree(app.replay.tree);
el.qRamp.style.background = qGradient();

// --- runs list, health, reports -------------------------------------------------------------

let pollTimer = 0;
let refreshes = 0; // refresh() calls made; an answer older than the one shown is dropped
let refreshShown = 0;

async function refresh() {
  clearTimeout(pollTimer);
  const mine = ++refreshes;
  const params = new URLSearchParams({ limit: String(app.limit), offset: "0" });
  if (el.filter.value) params.set("status", el.filter.value);
  try {
    const [health, page] = await Promise.all([api("/api/health"), api(`/api/runs?${params}`)]);
    if (mine < refreshShown) return;
    refreshShown = mine;
    renderHealth(health);
    app.runs = page.runs;
    el.runsError.hidden = true;
    renderRuns(page);
    const selected = app.run && page.runs.find((r) => r.id === app.run.id);
    if (selected && app.run.detail) {
      app.run.detail = { ...app.run.detail, ...selected };
      renderHeader();
    }
  } catch (err) {
    el.runsError.textContent = `Cannot load runs: ${err.message}`;
    el.runsError.hidden = false;
  }
  if (mine !== refreshes) return; // a newer call is under way and will set the next poll
  const live =
    app.runs.some((r) => LIVE.has(r.status)) ||
    (app.health && app.health.running + app.health.queued > 0);
  pollTimer = setTimeout(refresh, live ? POLL_LIVE_MS : POLL_IDLE_MS);
}

function renderHealth(health) {
  const first = app.health === null;
  app.health = health;
  el.health.innerHTML =
    `<span class="dot ${health.status === "ok" ? "ok" : "bad"}"></span>` +
    `${escapeHtml(health.status)} · ${health.running} running · ${health.queued} queued`;
  el.health.title = `database: ${health.database ?? "?"}`;
  if (first) setUpViewer(health.viewer_url);
}

let runsShown = "";

function renderRuns(page) {
  const key = JSON.stringify([page, app.run?.id ?? null, el.filter.value]);
  if (key === runsShown) return; // unchanged: keep the DOM (and the hover, the focus)
  runsShown = key;
  el.runsTotal.textContent = `(${page.total})`;
  el.runsMore.hidden = page.total <= page.runs.length;
  if (page.runs.length === 0) {
    const which = el.filter.value
      ? ` with status ${escapeHtml(el.filter.value)}`
      : " yet: launch one above";
    el.runs.innerHTML = `<li class="muted empty">No runs${which}.</li>`;
    return;
  }
  el.runs.innerHTML = page.runs
    .map((r) => {
      const live = LIVE.has(r.status);
      const figures = [
        `seed ${escapeHtml(r.seed)}`,
        r.planning_s !== null && r.planning_s !== undefined ? `plan ${seconds(r.planning_s)}` : "",
        r.execution_s !== null && r.execution_s !== undefined ? `exec ${seconds(r.execution_s)}` : "",
        // A run's queries are counted when it ends: a live one's are on its own page.
        live ? "" : `${r.queries ?? 0} queries`,
      ].filter(Boolean);
      const current = app.run && app.run.id === r.id;
      return `<li data-testid="run-row" data-run-id="${escapeHtml(r.id)}" data-status="${escapeHtml(r.status)}"
                 class="run-row${current ? " selected" : ""}" tabindex="0" role="button"
                 ${current ? 'aria-current="true"' : ""}>
        <div class="run-line">
          <span class="badge ${escapeHtml(r.status)}" data-testid="run-status" title="${escapeHtml(STATUS_TEXT[r.status] ?? "")}">${escapeHtml(r.status)}</span>
          <span class="run-title">${escapeHtml(r.scene)} · ${escapeHtml(r.planner)}</span>
        </div>
        <div class="run-figures" data-testid="run-figures">${figures.join(" · ")}</div>
        <div class="run-meta muted">${escapeHtml(r.id.slice(0, 8))} · ${escapeHtml(when(r.created_at))}</div>
      </li>`;
    })
    .join("");
}

el.runs.addEventListener("click", (e) => {
  const row = e.target.closest("[data-run-id]");
  if (row) selectRun(row.dataset.runId);
});
el.runs.addEventListener("keydown", (e) => {
  const row = e.target.closest("[data-run-id]");
  if (row && (e.key === "Enter" || e.key === " ")) {
    e.preventDefault();
    selectRun(row.dataset.runId);
  }
});
el.filter.addEventListener("change", () => {
  app.limit = PAGE;
  refresh();
});
el.runsMore.addEventListener("click", () => {
  app.limit += PAGE;
  refresh();
});
el.filter.insertAdjacentHTML(
  "beforeend",
  RUN_STATUSES.map((s) => `<option value="${s}" title="${escapeHtml(STATUS_TEXT[s])}">${s}</option>`).join(""),
);

async function loadReports() {
  try {
    const reports = await api("/api/reports");
    if (!Array.isArray(reports) || reports.length === 0) return;
    el.reportsList.innerHTML = reports
      .map(
        (r) =>
          `<li><a href="${escapeHtml(r.url)}" target="_blank" rel="noopener">` +
          `${escapeHtml(r.name)}</a></li>`,
      )
      .join("");
    el.reports.hidden = false;
  } catch {
    el.reports.hidden = true; // no reports route (yet): no area
  }
}

// --- the launch form -------------------------------------------------------------------------

async function loadForm() {
  try {
    const [scenes, models] = await Promise.all([api("/api/scenes"), api("/api/models")]);
    app.scenes = scenes;
    app.models = models;
  } catch (err) {
    showLaunchError(`Cannot load scenes and models: ${err.message}`);
    return;
  }
  el.scene.innerHTML = app.scenes
    .map((s) => `<option value="${escapeHtml(s.name)}">${escapeHtml(s.name)}</option>`)
    .join("");
  syncForm();
  const planners = [...el.planner.options].map((o) => o.value);
  benchPage.setChoices(app.scenes, planners, app.models);
  modelsPage.setScenes(app.scenes);
  modelsPage.setModels(app.models);
}

/** The models offered changed (a training job finished): every form offers the new ones. */
function setModels(models) {
  app.models = models;
  syncForm();
  benchPage.setModels(models);
}

function syncForm() {
  const scene = app.scenes.find((s) => s.name === el.scene.value);
  el.sceneDescription.textContent = scene
    ? `${scene.description}${scene.domain ? ` (${scene.domain} domain)` : ""}`
    : "";
  const learned = usesModel(el.planner.value);
  el.modelField.hidden = !learned;
  if (!learned) return;
  const models = app.models.filter((m) => !scene || !m.domain || m.domain === scene.domain);
  const chosen = el.model.value;
  el.model.innerHTML = models.length
    ? models
        .map((m) => {
          const kb = m.bytes ? ` · ${Math.round(m.bytes / 1024)} kB` : "";
          const name = escapeHtml(m.name);
          return `<option value="${name}">${name}${m.default ? " (default)" : ""}${kb}</option>`;
        })
        .join("")
    : `<option value="">none for this domain: per-stream priors</option>`;
  const keep = models.find((m) => m.name === chosen) ?? models.find((m) => m.default);
  if (keep) el.model.value = keep.name;
}

/** The learned planners (paper, learned and their variants such as learned:dead_ends=off). */
function usesModel(planner) {
  const name = String(planner ?? "").split(":")[0];
  return name === "learned" || name === "paper";
}

el.scene.addEventListener("change", syncForm);
el.planner.addEventListener("change", syncForm);

function showLaunchError(text) {
  el.launchError.textContent = text;
  el.launchError.hidden = false;
}

el.form.addEventListener("submit", async (e) => {
  e.preventDefault();
  el.launchError.hidden = true;
  const body = {
    scene: el.scene.value,
    planner: el.planner.value,
    seed: el.seed.value === "" ? 0 : Number(el.seed.value),
    budget_s: el.budget.value === "" ? 120 : Number(el.budget.value),
  };
  if (usesModel(body.planner) && el.model.value) body.model = el.model.value;
  if (el.maxQueries.value !== "") body.max_queries = Number(el.maxQueries.value);
  el.submit.disabled = true;
  el.submit.textContent = "Launching…";
  try {
    const run = await api("/api/runs", { method: "POST", body });
    await selectRun(run.id, run);
    refresh();
  } catch (err) {
    showLaunchError(err instanceof ApiError ? err.message : String(err));
  } finally {
    el.submit.disabled = false;
    el.submit.textContent = "Launch";
  }
});

// --- the selected run: one owner of its state, its events in bulk, then live ------------------

let token = 0;

/** Everything the page holds of one selected run; a switch of run makes a new one. */
function newRunState(id, detail = null) {
  return {
    id, // null: events given by loadEvents
    detail, // GET /api/runs/{id}
    token: ++token, // answers for an older selection are dropped
    ws: null, // the websocket of a live run
    done: false, // no more events will come
    caughtUp: false,
    retries: 0,
    loading: null, // {got, of}: stored events being read
    lastArrival: performance.now(), // when the newest event came (the skeleton clock)
    pickedSeen: undefined, // the 3D view's ghost clicks already seen (the first poll sets it)
    marks: { selected: performance.now() }, // when each part of opening it was done (ms)
    opening: id !== null, // its stored events are being read (plotly waits until they are)
  };
}

/** Forget everything of the run shown (tree, cursor, selection, search, inspector, legend,
 * charts, the 3D view's note) and make ``state`` the run shown. */
function resetRunView(state) {
  closeStream();
  stopPlay();
  app.run = state;
  app.replay.load([]);
  app.pending = [];
  app.follow = true;
  app.selectedId = null;
  app.search = { text: "", matches: [], at: -1, size: -1 };
  el.searchInput.value = "";
  view.setTree(app.replay.tree);
  el.viewerPicked.hidden = true;
  el.viewerPicked.textContent = "";
  el.tooltip.hidden = true;
  clearTimeout(chartTimer);
  chartTimer = 0;
  renderSearch();
  renderInspector();
  renderHeader();
  updateStep();
  drawCharts();
}

async function selectRun(id, run = null) {
  const state = newRunState(id, run);
  resetRunView(state);
  const mine = state.token;
  const current = () => app.run !== null && app.run.token === mine;
  history.replaceState(null, "", `#run=${encodeURIComponent(id)}`);
  for (const row of el.runs.querySelectorAll("[data-run-id]")) {
    const on = row.dataset.runId === id;
    row.classList.toggle("selected", on);
    if (on) row.setAttribute("aria-current", "true");
    else row.removeAttribute("aria-current");
  }
  scheduleViewer();
  // The run and its first page of events are asked for at once; the first page says how many
  // there are, so the others are asked for without waiting for the run.
  const detailAnswer = api(`/api/runs/${encodeURIComponent(id)}`);
  detailAnswer.then(
    (detail) => {
      if (!current()) return;
      state.detail = detail;
      state.marks.detail = performance.now();
      renderHeader();
      scheduleCharts();
    },
    (err) => {
      if (!current()) return;
      el.header.innerHTML = `<span class="error-text">Run ${escapeHtml(id)}: ${escapeHtml(err.message)}</span>`;
    },
  );
  let first;
  try {
    first = await eventPage(id, -1);
  } catch (err) {
    if (!current()) return;
    if (err.status === 404) {
      state.done = true; // no such run: nothing will come (the detail's answer says so)
      state.opening = false;
      updateStep();
      scheduleCharts();
      return;
    }
    first = null;
  }
  if (!current()) return;
  let last;
  let done;
  try {
    if (first === null) throw new ApiError(0, "cannot read its events");
    ({ last, done } = await loadStored(state, first));
  } catch (err) {
    if (!current()) return;
    el.header.insertAdjacentHTML("beforeend", `<span class="error-text">Cannot read its events: ${escapeHtml(err.message)}</span>`);
    state.loading = null;
    done = false;
    last = app.replay.events.length ? app.replay.events.at(-1).seq : -1;
  }
  if (!current()) return;
  state.opening = false;
  pollPicked(); // at once: the clicks made before this run was shown are told from later ones
  if (done) {
    state.done = true; // a finished run: everything is here, nothing is live
    updateStep();
    scheduleCharts();
    return;
  }
  scheduleCharts();
  openStream(mine, last); // still going: the rest comes over the websocket
}

/** One page of a run's stored events (GET /api/runs/{id}/events), parsed as it arrives. */
async function eventPage(id, after) {
  const response = await fetch(`/api/runs/${encodeURIComponent(id)}/events?after=${after}&limit=${EVENT_PAGE}`, {
    headers: { Accept: "application/json" },
  });
  if (!response.ok) throw new ApiError(response.status, `${response.status}: cannot read events`);
  return response.json();
}

/**
 * Read the run's stored events in pages (``first``, page 0, says the last seq; then
 * PAGES_AT_ONCE at once: a run's seqs have no gaps, so page k starts after seq
 * k * EVENT_PAGE - 1; with gaps pages overlap and ``append`` drops the repeats), fold them and
 * draw the last step. Returns the last seq read and whether the run is over with nothing
 * after it.
 */
async function loadStored(state, first) {
  const lastSeq = first.last_seq;
  const pages = Math.max(1, Math.ceil((lastSeq + 1) / EVENT_PAGE));
  state.loading = { got: first.events.length, of: lastSeq + 1 };
  renderEmpty();
  const got = new Array(pages);
  got[0] = first;
  let next = 1;
  const worker = async () => {
    while (next < pages && app.run === state) {
      const k = next++;
      got[k] = await eventPage(state.id, k * EVENT_PAGE - 1);
      state.loading.got += got[k].events.length;
      renderEmpty();
    }
  };
  await Promise.all(Array.from({ length: Math.min(PAGES_AT_ONCE, pages - 1) }, worker));
  if (app.run !== state) return { last: -1, done: false };
  state.marks.read = performance.now();
  for (const page of got) app.replay.append(page.events);
  let tail = got[pages - 1];
  // A live run (or a full last page) may have more: read on from the last seq.
  while (!tail.done && tail.events.length === EVENT_PAGE) {
    tail = await eventPage(state.id, tail.next_after);
    if (app.run !== state) return { last: -1, done: false };
    app.replay.append(tail.events);
  }
  state.loading = null;
  state.lastArrival = performance.now();
  if (app.follow) app.replay.goTo(app.replay.last);
  state.marks.folded = performance.now();
  view.draw();
  state.marks.drawn = performance.now();
  updateStep();
  const last = app.replay.events.length ? app.replay.events.at(-1).seq : -1;
  return { last, done: tail.done };
}

function openStream(mine, after) {
  const ws = new WebSocket(streamUrl(app.run.id, after));
  app.run.ws = ws;
  updateStep();
  ws.onmessage = (msg) => {
    if (!app.run || app.run.token !== mine) return;
    app.run.retries = 0;
    const data = JSON.parse(msg.data);
    if (data.type === "control") {
      if (data.kind === "caught_up") app.run.caughtUp = true;
      else if (data.kind === "end") finishStream(mine, data.status);
      return; // "resync": the server re-sends from its store; nothing to do here
    }
    app.pending.push(data);
    app.run.lastArrival = performance.now();
    if (!app.flushQueued) {
      app.flushQueued = true;
      requestAnimationFrame(flush);
    }
  };
  ws.onclose = () => {
    if (!app.run || app.run.token !== mine || app.run.done) return;
    // Dropped before the end: reconnect, asking for what came after the last event we have.
    const wait = RECONNECT_MS[Math.min(app.run.retries, RECONNECT_MS.length - 1)];
    app.run.retries += 1;
    setTimeout(() => {
      if (app.run && app.run.token === mine && !app.run.done) {
        const pending = app.pending.length ? app.pending.at(-1).seq : -1;
        const stored = app.replay.events.length ? app.replay.events.at(-1).seq : -1;
        openStream(mine, Math.max(pending, stored));
      }
    }, wait);
  };
}

function closeStream() {
  if (app.run && app.run.ws) {
    app.run.done = true;
    app.run.ws.onclose = null;
    app.run.ws.close();
  }
}

async function finishStream(mine, status) {
  flush();
  app.run.done = true;
  app.run.ws.onclose = null;
  updateStep();
  try {
    const detail = await api(`/api/runs/${encodeURIComponent(app.run.id)}`);
    if (app.run && app.run.token === mine) {
      app.run.detail = detail;
      renderHeader();
      scheduleCharts();
    }
  } catch {
    if (app.run.detail) app.run.detail.status = status;
  }
  refresh();
}

function flush() {
  app.flushQueued = false;
  if (app.pending.length === 0) return;
  const batch = app.pending;
  app.pending = [];
  app.replay.append(batch);
  if (app.follow) app.replay.goTo(app.replay.last);
  updateStep();
  view.requestDraw();
}

/** The run streams in over its websocket (the live badge says so). */
function isLive() {
  return app.run !== null && app.run.id !== null && app.run.ws !== null && !app.run.done;
}

/** Queries a user reads in the header: the run's count once it is over (what its row says),
 * else the tree's so far; reused answers apart (planner/figures.py). */
function headerQueries(d) {
  const tree = app.replay.tree;
  const over = d && !LIVE.has(d.status) && app.run.done;
  const reused = tree.reused ? ` <span class="muted">(+${count(tree.reused)} reused)</span>` : "";
  if (over) return `<b data-testid="header-queries">${count(d.queries ?? 0)}</b> queries${reused}`;
  return `<b data-testid="header-queries">${count(tree.sampled)}</b> queries so far${reused}`;
}

function renderHeader() {
  const run = app.run;
  if (run === null) {
    el.header.innerHTML = `<span class="muted">Select a run on the left, or launch one.</span>`;
    return;
  }
  if (run.id === null) {
    el.header.innerHTML =
      `<span class="run-name">Loaded events</span>` +
      `<span class="muted">${app.replay.events.length} events</span>`;
    return;
  }
  const d = run.detail;
  if (!d) {
    el.header.innerHTML =
      `<span class="run-name">Run ${escapeHtml(run.id.slice(0, 8))}</span>` +
      `<span class="muted">loading…</span>`;
    return;
  }
  const tree = app.replay.tree;
  const figures = [
    `planning <b>${seconds(d.planning_s)}</b>`,
    `execution <b>${seconds(d.execution_s)}</b>`,
    `<span id="header-queries-wrap">${headerQueries(d)}</span>`,
  ];
  if (d.oracle_s !== null && d.oracle_s !== undefined) figures.push(`oracle ${seconds(d.oracle_s)}`);
  if (tree.planList.length) {
    const later = tree.planList.length - (tree.plans?.plans?.length ?? 0);
    figures.push(
      `<span data-testid="header-skeletons">${tree.planList.length} skeletons${later ? ` (${later} arrived during the search)` : ""}</span>`,
    );
  }
  const message = d.message
    ? `<span class="muted run-message" title="${escapeHtml(d.message)}">${escapeHtml(d.message)}</span>`
    : "";
  const cancel = LIVE.has(d.status)
    ? `<button type="button" id="btn-cancel" data-testid="btn-cancel" class="danger">Cancel</button>`
    : "";
  el.header.innerHTML = `
    <span class="run-name" title="${escapeHtml(d.id)}">Run ${escapeHtml(d.id.slice(0, 8))}</span>
    <span>${escapeHtml(d.scene)} · ${escapeHtml(d.planner)} · seed ${escapeHtml(d.seed)}${d.config?.model_name ? ` · model <a href="#model=${encodeURIComponent(d.config.model_name)}" data-testid="run-model">${escapeHtml(d.config.model_name)}</a>` : ""}</span>
    <span class="badge ${escapeHtml(d.status)}" data-testid="run-status" title="${escapeHtml(STATUS_TEXT[d.status] ?? "")}">${escapeHtml(d.status)}</span>
    <span class="figures" data-testid="run-header-figures">${figures.join(" · ")}</span>
    ${message}
    ${cancel}
    ${compareControl(d)}`;
  bindCompare(d);
  const button = $("btn-cancel");
  if (button) {
    button.addEventListener("click", async () => {
      button.disabled = true;
      try {
        await api(`/api/runs/${encodeURIComponent(d.id)}`, { method: "DELETE" });
      } catch (err) {
        el.header.insertAdjacentHTML("beforeend", `<span class="error-text">${escapeHtml(err.message)}</span>`);
      }
      refresh();
    });
  }
}

/** "Compare with": the other runs of the same scene (then of the same domain); runs of other
 * domains are never offered first, and nothing is chosen when no run shares the scene. */
function compareControl(d) {
  const domainOf = (r) => app.scenes.find((s) => s.name === r.scene)?.domain ?? null;
  const others = app.runs.filter((r) => r.id !== d.id);
  const same = others.filter((r) => r.scene === d.scene);
  const kin = others.filter((r) => r.scene !== d.scene && domainOf(r) !== null && domainOf(r) === domainOf(d));
  if (same.length + kin.length === 0) return "";
  const option = (r) =>
    `<option value="${escapeHtml(r.id)}">${escapeHtml(r.scene)} · ${escapeHtml(r.planner)} · seed ${escapeHtml(r.seed)} · ${escapeHtml(r.id.slice(0, 8))}</option>`;
  const head = same.length ? "" : `<option value="" selected disabled>no other run of ${escapeHtml(d.scene)}</option>`;
  const group = (label, runs) => (runs.length ? `<optgroup label="${escapeHtml(label)}">${runs.map(option).join("")}</optgroup>` : "");
  return `<span class="compare-with"><select id="compare-with" data-testid="compare-with" aria-label="run to compare with">${head}${group(d.scene, same)}${group("other scenes of its domain", kin)}</select>
    <button type="button" id="btn-compare" data-testid="btn-compare">Compare</button></span>`;
}

function bindCompare(d) {
  const button = $("btn-compare");
  if (!button) return;
  button.addEventListener("click", () => {
    const other = $("compare-with").value;
    if (!other) return;
    location.hash = `#compare=${encodeURIComponent(d.id)},${encodeURIComponent(other)}`;
  });
}

// --- stepping --------------------------------------------------------------------------------

/** Move to step k (clamped); a user action stops following the live end unless it reaches it. */
function goTo(k) {
  const replay = app.replay;
  const step = replay.goTo(k);
  app.follow = step >= replay.last;
  updateStep();
  view.requestDraw();
  return step;
}

function updateStep() {
  const replay = app.replay;
  const tree = replay.tree;
  const step = replay.step;
  const last = replay.last;
  const any = last >= 0;
  el.slider.min = "0";
  el.slider.max = String(Math.max(last, 0));
  el.slider.value = String(Math.max(step, 0));
  el.slider.disabled = !any;
  for (const b of [el.first, el.back, el.play, el.forward, el.last]) b.disabled = !any;
  el.back.disabled = step <= 0;
  el.first.disabled = step <= 0;
  el.forward.disabled = step >= last;
  el.stepLabel.textContent = any ? `step ${step} / ${last}` : "step – / –";
  el.stepLabel.dataset.step = String(step);
  el.stepLabel.dataset.last = String(last);
  const live = isLive();
  el.liveBadge.hidden = !live;
  el.liveBadge.textContent = app.follow ? "● live" : "● live run (last event button follows it)";
  el.liveBadge.classList.toggle("paused", !app.follow);
  const n = tree.nodeCount;
  const failed = tree.failed ? ` · ${count(tree.failed)} failed` : "";
  el.nodeCount.textContent = `${count(n)} node${n === 1 ? "" : "s"}${failed}`;
  el.nodeCount.dataset.nodes = String(n);
  el.stepEvent.textContent = step >= 0 ? describe(replay.events[step]) : "";
  if (app.search.text && app.search.size !== tree.order.length) runSearch(app.search.text, false);
  renderEmpty();
  renderLegend();
  if (app.selectedId !== null) renderInspector();
  const queries = $("header-queries-wrap"); // a live run's queries so far
  if (queries && app.run?.detail) queries.innerHTML = headerQueries(app.run.detail);
  scheduleCharts();
  scheduleViewer();
}

/** What the skeleton source is doing, in words (null when it is not at work). */
function skeletonWork() {
  const tree = app.replay.tree;
  const live = isLive() && app.follow;
  if (tree.progress !== null) {
    const p = tree.progress;
    const extra = live ? (performance.now() - app.run.lastArrival) / 1000 : 0;
    const what = tree.plans === null ? "Computing skeletons" : "Computing more skeletons";
    return `${what}: ${p.message} (${p.phase}, ${seconds(p.seconds + extra)})`;
  }
  if (live && tree.plans === null && tree.run !== null) {
    const ev = app.replay.events[app.replay.step];
    const t = (ev?.t ?? 0) + (performance.now() - app.run.lastArrival) / 1000;
    return `Computing skeletons… ${seconds(t)} since the run started`;
  }
  return null;
}

let skeletonTimer = 0;

function renderEmpty() {
  const tree = app.replay.tree;
  const run = app.run;
  let text = "";
  const work = skeletonWork();
  if (run === null) text = "No run selected.";
  else if (run.loading) {
    const { got, of } = run.loading;
    text = `Loading ${count(got)} of ${count(of)} events…`;
  } else if (tree.nodeCount === 0) {
    const planner = run.detail?.planner ?? tree.run?.planner;
    if (planner === "sequential") {
      text = "The sequential planner binds skeletons in order and builds no search tree; see the charts below.";
    } else if (work !== null) {
      text = work;
    } else if (app.replay.last < 0) {
      if (run.detail?.status === STATUS.QUEUED) text = "Queued: waiting for a worker.";
      else text = isLive() || !run.done ? "Waiting for the run's first events…" : "This run has no events.";
    } else if (tree.end !== null && app.replay.step === app.replay.last) {
      text = "This run ended without a search tree.";
    } else {
      text = "No tree yet at this step (the skeletons come first).";
    }
  }
  el.treeEmpty.textContent = text;
  el.treeEmpty.hidden = text === "";
  const note = tree.nodeCount > 0 ? work : null;
  el.skeletonNote.textContent = note ?? "";
  el.skeletonNote.hidden = note === null;
  // While the source works on a live run, its clock ticks on the page between its events.
  clearTimeout(skeletonTimer);
  if (work !== null && isLive()) skeletonTimer = setTimeout(renderEmpty, 1000);
}

/** The legend's Q scale is the one the tree is drawn on now (the same function), with the
 * selected node's Q marked on it. */
function renderLegend() {
  const tree = app.replay.tree;
  const range = tree.nodeCount > 0 ? view.scaleOf(tree) : null;
  el.qLegend.hidden = range === null;
  if (range === null) {
    delete el.qLegend.dataset.lo;
    delete el.qLegend.dataset.hi;
    return;
  }
  el.qLo.textContent = seconds(range.lo);
  el.qHi.textContent = seconds(range.hi);
  el.qLegend.dataset.lo = String(range.lo);
  el.qLegend.dataset.hi = String(range.hi);
  const node = app.selectedId === null ? undefined : tree.byId.get(app.selectedId);
  const q = node === undefined ? null : tree.qOf(node);
  el.qMark.hidden = q === null;
  el.qSelected.hidden = q === null;
  if (q === null) {
    delete el.qLegend.dataset.selected;
    return;
  }
  const f = range.hi > range.lo ? (q - range.lo) / (range.hi - range.lo) : 0;
  el.qMark.style.left = `${Math.min(Math.max(f, 0), 1) * 100}%`;
  const beyond = f < 0 ? " (below the scale)" : f > 1 ? " (above the scale)" : "";
  el.qSelected.textContent = `#${node.id}: ${seconds(q)}${beyond}`;
  el.qLegend.dataset.selected = String(q);
}

function describe(ev) {
  const t = `t=${num(ev.t, 2)} s · #${ev.seq} `;
  switch (ev.type) {
    case EVENT.RUN_STARTED:
      return `${t}run started: ${ev.scene}, ${ev.planner}, seed ${ev.seed}`;
    case EVENT.SKELETON_PROGRESS:
      return `${t}skeleton source, ${ev.phase}: ${ev.message} (${seconds(ev.seconds)})`;
    case EVENT.ABSTRACT_PLANS_FOUND:
      return `${t}${ev.plans.length} abstract plans in ${seconds(ev.seconds)}`;
    case EVENT.SKELETONS_ADDED: {
      const idx = ev.plans.map((p) => p.index);
      const which = idx.length === 1 ? ` (plan ${idx[0]})` : idx.length ? ` (plans ${Math.min(...idx)} to ${Math.max(...idx)})` : "";
      const learned = ev.learned?.length ? `; learned ${ev.learned.length}: ${ev.learned.slice(0, 3).join(", ")}${ev.learned.length > 3 ? ", …" : ""}` : "";
      const n = ev.plans.length;
      return `${t}${n} more skeleton${n === 1 ? "" : "s"}${which} in ${seconds(ev.seconds)}, asked for ${ev.reason}${learned}`;
    }
    case EVENT.NODE_ADDED:
      return `${t}node ${ev.node_id} added: ${ev.label}`;
    case EVENT.STREAM_QUERIED:
      return (
        `${t}query ${ev.stream}(${ev.input_names.join(" ")}) ${ev.success ? "ok" : "FAILED"} ` +
        (ev.reused_from !== null && ev.reused_from !== undefined
          ? `reused from node ${ev.reused_from}`
          : `in ${seconds(ev.wall_s)}`) +
        ` → node ${ev.node_id}${ev.error ? `: ${ev.error}` : ev.reason ? `: ${ev.reason}` : ""}`
      );
    case EVENT.MODEL_PREDICTION:
      return `${t}prediction for node ${ev.node_id}: Q ${num(ev.q)} s, P_S ${num(ev.p_s)}`;
    case EVENT.NODE_VISITED:
      return `${t}back-up node ${ev.node_id}: ${ev.visits} visits, value ${num(ev.value)}`;
    case EVENT.SOLUTION_FOUND:
      return (
        `${t}solution at node ${ev.node_id} (plan ${ev.plan_index}): ` +
        `planning ${seconds(ev.planning_s)}, execution ${seconds(ev.execution_s)}`
      );
    case EVENT.RUN_FINISHED:
      return `${t}run finished: ${ev.status} (${ev.message})`;
    case EVENT.RUN_FAILED:
      return `${t}run failed: ${ev.error}`;
    case EVENT.RUN_CANCELLED:
      return `${t}run cancelled: ${ev.reason}`;
    default:
      return `${t}${ev.type}`;
  }
}

let playFrame = 0;

function startPlay() {
  const replay = app.replay;
  if (replay.last < 0) return;
  if (replay.step >= replay.last) goTo(0);
  app.playing = true;
  el.play.innerHTML = PAUSE_ICON;
  el.play.setAttribute("aria-label", "pause");
  let carry = 0;
  let before = performance.now();
  const tick = (now) => {
    if (!app.playing) return;
    carry += ((now - before) / 1000) * Number(el.speed.value);
    before = now;
    const steps = Math.floor(carry);
    if (steps > 0) {
      carry -= steps;
      goTo(replay.step + steps);
    }
    if (replay.step >= replay.last) {
      stopPlay(); // at the end: a live run is followed from here
      return;
    }
    playFrame = requestAnimationFrame(tick);
  };
  playFrame = requestAnimationFrame(tick);
}

function stopPlay() {
  app.playing = false;
  cancelAnimationFrame(playFrame);
  el.play.innerHTML = PLAY_ICON;
  el.play.setAttribute("aria-label", "play");
}

el.play.addEventListener("click", () => (app.playing ? stopPlay() : startPlay()));
el.back.addEventListener("click", () => {
  stopPlay();
  goTo(app.replay.step - 1);
});
el.forward.addEventListener("click", () => {
  stopPlay();
  goTo(app.replay.step + 1);
});
el.first.addEventListener("click", () => {
  stopPlay();
  goTo(0);
});
el.last.addEventListener("click", () => {
  stopPlay();
  goTo(app.replay.last);
});
el.slider.addEventListener("input", () => {
  stopPlay();
  goTo(Number(el.slider.value));
});
el.fit.addEventListener("click", () => view.fit());

document.addEventListener("keydown", (e) => {
  if (e.target.closest("input, select, textarea")) return; // the slider has its own keys
  if ((e.key === " " || e.key === "Enter") && e.target.closest("button, a, [role=button]")) return;
  if (e.altKey || e.ctrlKey || e.metaKey) return;
  if (currentPage !== "runs") return;
  if (e.key === "/") {
    e.preventDefault();
    el.searchInput.focus();
    return;
  }
  const keys = {
    ArrowLeft: () => goTo(app.replay.step - 1),
    ArrowRight: () => goTo(app.replay.step + 1),
    Home: () => goTo(0),
    End: () => goTo(app.replay.last),
    " ": () => (app.playing ? stopPlay() : startPlay()),
  };
  const action = keys[e.key];
  if (action === undefined || app.replay.last < 0) return;
  e.preventDefault();
  if (e.key !== " ") stopPlay();
  action();
});

// --- searching the tree: by node id (#12), stream, object or label ----------------------------

/** The text a node is found by: its id, stream, label, the names and labels of its inputs and
 * outputs, and its inputs' values (objects such as "b3" among them). */
function haystack(node, tree) {
  if (node._hay !== undefined) return node._hay;
  const q = tree.queries.get(node.id);
  const parts = [node.stream ?? "", node.label, ...node.outputNames, ...node.outputLabels];
  if (node.stream === null && node.parent !== null) {
    const plan = tree.plan(node.planIndex);
    parts.push(`plan ${node.planIndex}`, ...(plan?.actions ?? []));
  }
  if (q) parts.push(...(q.input_names ?? []), ...(q.input_labels ?? []), JSON.stringify(q.inputs ?? []));
  node._hay = parts.join(" ").toLowerCase();
  return node._hay;
}

function runSearch(text, jump = true) {
  const tree = app.replay.tree;
  const query = text.trim().toLowerCase();
  const matches = [];
  if (query) {
    const id = /^#?(\d+)$/.exec(query);
    if (id) {
      const node = tree.byId.get(Number(id[1]));
      if (node && !(node.implicit && tree.nodeCount === 0)) matches.push(node.id);
    } else {
      for (const node of tree.order) {
        if (node.implicit && tree.nodeCount === 0) continue;
        if (haystack(node, tree).includes(query)) {
          matches.push(node.id);
          if (matches.length >= SEARCH_MOST) break;
        }
      }
    }
  }
  const before = app.search;
  app.search = { text, matches, at: before.text === text ? Math.min(before.at, matches.length - 1) : -1, size: tree.order.length };
  view.matches = new Set(matches);
  view.requestDraw();
  renderSearch();
  if (jump && matches.length && app.search.at < 0) searchStep(1);
}

/** Select and show the next (``dir`` 1) or previous (-1) match. */
function searchStep(dir) {
  const s = app.search;
  if (s.matches.length === 0) return;
  s.at = (s.at + dir + s.matches.length) % s.matches.length;
  const id = s.matches[s.at];
  app.selectedId = id;
  view.selectedId = id;
  view.centreOn(id, 1);
  renderInspector();
  renderLegend();
  renderSearch();
  scheduleViewer();
}

function renderSearch() {
  const s = app.search;
  const n = s.matches.length;
  el.searchCount.textContent = s.text.trim()
    ? n === 0
      ? "no match"
      : `${s.at >= 0 ? `${s.at + 1} of ` : ""}${n >= SEARCH_MOST ? `${SEARCH_MOST}+` : n} match${n === 1 ? "" : "es"}`
    : "";
  el.searchCount.dataset.matches = String(n);
  el.searchPrev.disabled = n === 0;
  el.searchNext.disabled = n === 0;
}

let searchTimer = 0;
el.searchInput.addEventListener("input", () => {
  clearTimeout(searchTimer);
  searchTimer = setTimeout(() => runSearch(el.searchInput.value), 150);
});
el.searchInput.addEventListener("keydown", (e) => {
  if (e.key === "Enter") {
    e.preventDefault();
    clearTimeout(searchTimer);
    if (app.search.text !== el.searchInput.value) runSearch(el.searchInput.value);
    else searchStep(e.shiftKey ? -1 : 1);
  } else if (e.key === "Escape") {
    el.searchInput.value = "";
    runSearch("");
  }
});
el.searchNext.addEventListener("click", () => searchStep(1));
el.searchPrev.addEventListener("click", () => searchStep(-1));

// --- the node inspector ----------------------------------------------------------------------

function renderInspector() {
  const tree = app.replay.tree;
  const id = app.selectedId;
  view.selectedId = id;
  const node = id === null ? undefined : tree.byId.get(id);
  el.inspectorHint.hidden = id !== null;
  if (id === null) {
    el.inspectorTitle.textContent = "Node";
    el.inspectorBody.innerHTML = "";
    return;
  }
  if (node === undefined || (node.implicit && tree.nodeCount === 0)) {
    el.inspectorTitle.textContent = `Node ${id}`;
    el.inspectorBody.innerHTML = `<p class="muted">Not in the tree at this step.</p>`;
    return;
  }
  const query = tree.queries.get(node.id);
  const rows = [];
  const row = (label, html, testid = "") =>
    rows.push(`<dt>${label}</dt><dd${testid ? ` data-testid="${testid}"` : ""}>${html}</dd>`);
  const isRoot = node.parent === null;
  const isPlan = !isRoot && node.stream === null;
  el.inspectorTitle.textContent = isRoot ? "Root" : isPlan ? `Stream plan ${node.planIndex}` : `Node ${node.id}`;
  row("Node", `#${node.id}${isRoot ? "" : ` · plan ${node.planIndex} · depth ${node.depth}`}`, "inspector-node");
  row("Stream", isRoot || isPlan ? "—" : `<code>${escapeHtml(node.stream)}</code>`, "inspector-stream");
  const outcome = isRoot ? "root" : isPlan ? "stream plan" : node.success ? "ok" : "failed";
  row("Outcome", `<span class="outcome ${outcome.replace(" ", "-")}">${outcome}</span>`, "inspector-outcome");
  if (node.label && !isRoot) row("Label", `<code>${escapeHtml(node.label)}</code>`);
  if (query) {
    row("Inputs", kvList(query.input_names, query.inputs, query.input_labels), "inspector-inputs");
  }
  if (!isRoot && !isPlan) {
    row("Outputs", kvList(node.outputNames, node.outputs, node.outputLabels), "inspector-outputs");
  }
  if (query) {
    row("Wall / CPU", `${seconds(query.wall_s)} / ${seconds(query.cpu_s)}`, "inspector-seconds");
    if (query.execution_s) row("Execution", seconds(query.execution_s));
    if (query.reused_from !== null && query.reused_from !== undefined) {
      row("Reused", `the answer of node ${query.reused_from} (same query; no sampler ran)`, "inspector-reused");
    }
    if (query.error) row("Error", `<span class="error-text">${escapeHtml(query.error)}</span>`, "inspector-error");
    if (query.reason) row("Why", escapeHtml(query.reason), "inspector-reason");
  }
  const visits = node.visit
    ? `${node.visit.visits} / ${num(node.visit.value)}`
    : `<span class="muted">not visited</span>`;
  row("Visits / value", visits, "inspector-visits");
  const failedKids = node.children.filter((c) => !c.success).length;
  row("Children", `${node.children.length}${failedKids ? ` (${failedKids} failed)` : ""}`);
  let html = `<dl class="kv">${rows.join("")}</dl>`;
  const noModels =
    tree.run && !usesModel(tree.run.planner)
      ? ` (the ${escapeHtml(tree.run.planner)} planner has no models)`
      : "";
  if (!isRoot && !isPlan) html += thisQuery(node, query, noModels);
  html += nextQuery(node, tree, noModels);
  const plan = tree.plan(node.planIndex);
  if (plan && !isRoot) {
    const streams = plan.streams
      .map((s, i) => `<li class="${i + 1 === node.depth ? "here" : ""}">${escapeHtml(s)}</li>`)
      .join("");
    const actions = plan.actions.map((a) => `<li>${escapeHtml(a)}</li>`).join("");
    const batch = plan.batch ? `; arrived during the search, t=${num(plan.at, 2)} s (batch ${plan.batch + 1})` : "";
    const summary =
      `Stream plan ${plan.index}: ${plan.streams.length} streams, ` +
      `${plan.actions.length} actions (cost ${num(plan.cost)})${batch}`;
    html += `<details class="plan"${isPlan ? " open" : ""} data-testid="inspector-plan"><summary>${summary}</summary>
      <ol>${streams}</ol><p class="muted">actions</p><ol>${actions}</ol></details>`;
  }
  if (!isRoot && !isPlan) {
    const raw = JSON.stringify({ inputs: query?.inputs ?? null, outputs: node.outputs }, null, 1);
    const shown = raw.length > 20000 ? `${raw.slice(0, 20000)}\n…` : raw;
    html += `<details class="raw"><summary>Raw values</summary><pre>${escapeHtml(shown)}</pre></details>`;
  }
  el.inspectorBody.innerHTML = html;
}

/** This node's query: what the model predicts of it (its parent's prediction of the next
 * query from there: the models are fixed during a run, so it is what they said before the
 * query; a rollout's predictions are reported after it) beside what happened: P_S against the
 * outcome, R_S or R_F against its seconds, R_M against its trajectory's. */
function thisQuery(node, query, noModels) {
  const e = node.parent?.pred ?? null;
  const reused = query && query.reused_from !== null && query.reused_from !== undefined;
  const outcome = reused ? "ok (reused; no sampler ran)" : node.success ? "ok" : "failed";
  if (!e) {
    return `<p class="muted" data-testid="inspector-pva">No prediction was made for this query${noModels}; it came out <b>${outcome}</b>.</p>`;
  }
  const wall = query && !reused ? seconds(query.wall_s) : "–";
  const seconds_ = node.success ? ["R<sub>S</sub>", e.r_s, "seconds of a successful query"] : ["R<sub>F</sub>", e.r_f, "seconds of a failed query"];
  const exec = query ? seconds(query.execution_s ?? 0) : "–";
  const hit = (node.success && e.p_s >= 0.5) || (!node.success && e.p_s < 0.5);
  return `<table class="pred pva" data-testid="inspector-pva">
    <caption>This query: the model's prediction (#${node.parent.id}'s next query) and what happened</caption>
    <tr><th></th><th>predicted</th><th>actual</th></tr>
    <tr data-row="p_s"><th title="success probability">P<sub>S</sub></th><td>${num(e.p_s)}</td><td class="${hit ? "" : "bad-text"}">${outcome}</td></tr>
    <tr data-row="${node.success ? "r_s" : "r_f"}"><th title="${seconds_[2]}">${seconds_[0]}</th><td>${seconds(seconds_[1])}</td><td>${wall}</td></tr>
    <tr data-row="r_m"><th title="seconds to execute the trajectory it produces">R<sub>M</sub></th><td>${seconds(e.r_m)}</td><td>${exec}</td></tr>
  </table>`;
}

/** The node's own prediction (of the next query from it) beside what its children's queries
 * did so far; for a node without one, whose Q colours it. */
function nextQuery(node, tree, noModels) {
  const p = node.pred;
  if (!p) {
    const q = tree.qOf(node);
    const from = tree.predictedAncestor(node);
    const inherited = q !== null && q !== undefined && from
      ? ` Coloured by #${from.id}'s Q, ${seconds(q)}: the cost expected when the search went down this branch.`
      : "";
    return `<p class="muted" data-testid="inspector-prediction">No model prediction of its own${noModels}.${inherited}</p>`;
  }
  const kids = node.children;
  const sampled = kids.filter((c) => {
    const q = tree.queries.get(c.id);
    return !(q && q.reused_from !== null && q.reused_from !== undefined);
  });
  const ok = sampled.filter((c) => c.success);
  const mean = (list, f) => (list.length ? list.reduce((a, c) => a + f(c), 0) / list.length : null);
  const wall = (c) => tree.queries.get(c.id)?.wall_s ?? 0;
  const exec = (c) => tree.queries.get(c.id)?.execution_s ?? 0;
  const failed = sampled.filter((c) => !c.success);
  const rate = sampled.length ? `${ok.length} of ${sampled.length} ok (${num(ok.length / sampled.length, 2)})` : "no query yet";
  return `<table class="pred" data-testid="inspector-prediction">
    <caption>Next query from this node: predicted, and its children so far</caption>
    <tr><th></th><th>predicted</th><th>children</th></tr>
    <tr data-row="p_s"><th title="success probability">P<sub>S</sub></th><td>${num(p.p_s)}</td><td>${rate}</td></tr>
    <tr data-row="r_s"><th title="seconds of a successful query">R<sub>S</sub></th><td>${seconds(p.r_s)}</td><td>${seconds(mean(ok, wall))}</td></tr>
    <tr data-row="r_f"><th title="seconds of a failed query">R<sub>F</sub></th><td>${seconds(p.r_f)}</td><td>${seconds(mean(failed, wall))}</td></tr>
    <tr data-row="r_m"><th title="seconds to execute the trajectory">R<sub>M</sub></th><td>${seconds(p.r_m)}</td><td>${seconds(mean(ok, exec))}</td></tr>
    <tr><th title="expected seconds still to spend: execution of the trajectories bound so far + Eq. 4 for the rest">Q</th><td colspan="2"><b>${seconds(p.q)}</b></td></tr>
  </table>`;
}

/** Names = values; a value as the domain labels it (its value type's label), else as JSON. */
function kvList(names, values, labels) {
  const items = values.map((v, i) => {
    const name = names?.[i] ?? `#${i}`;
    const text = labels?.[i] || value(v);
    return `<li><code>${escapeHtml(name)}</code> = ${escapeHtml(text)}</li>`;
  });
  return items.length ? `<ul class="values">${items.join("")}</ul>` : `<span class="muted">none</span>`;
}

function showTooltip(hit, e) {
  if (!hit || !e) {
    el.tooltip.hidden = true;
    return;
  }
  const rect = el.canvas.getBoundingClientRect();
  if (hit.fan) {
    const fan = hit.fan;
    el.tooltip.textContent = `${fan.nodes.length} failed ${fan.nodes[0].stream} queries of #${fan.parent.id}, folded: a click opens them`;
  } else {
    const node = hit;
    const tree = app.replay.tree;
    const q = tree.qOf(node);
    const own = node.pred !== null;
    const qText = q !== null && q !== undefined ? ` · Q ${seconds(q)}${own ? "" : " (an ancestor's)"}` : "";
    const fail = node.parent !== null && node.stream !== null && !node.success ? " · failed" : "";
    el.tooltip.textContent = `#${node.id} ${nodeText(node) || shortLabel(node)}${fail}${qText}`;
  }
  el.tooltip.style.left = `${e.clientX - rect.left + 12}px`;
  el.tooltip.style.top = `${e.clientY - rect.top + 12}px`;
  el.tooltip.hidden = false;
}

// --- charts ------------------------------------------------------------------------------------

let chartTimer = 0;

/** Redraw the charts soon; a live run's stream of events redraws them at most 4 times a second. */
function scheduleCharts() {
  if (chartTimer) return;
  chartTimer = setTimeout(() => {
    chartTimer = 0;
    drawCharts();
  }, CHART_DELAY_MS);
}

function drawCharts() {
  if (!window.Plotly && !app.run?.opening) loadPlotly();
  if (app.run === null) {
    clearChart(el.chartQueries, "Queries per stream: select a run.");
    clearChart(el.chartTime, "Time split: select a run.");
    return;
  }
  const tree = app.replay.tree;
  let counts = Object.fromEntries(tree.counts);
  let note = app.replay.step < app.replay.last ? `at step ${app.replay.step}` : "";
  const stored = app.run.detail?.query_counts;
  if (tree.counts.size === 0 && stored && Object.keys(stored).length && app.replay.step >= app.replay.last) {
    counts = stored; // e.g. the sequential planner: no query events, but the store counted them
    note = "from the run store";
  }
  let empty = "no stream queries yet";
  if (Object.keys(counts).length === 0 && app.run.detail?.queries && !isLive()) {
    empty = `${app.run.detail.queries} queries, not reported one by one by this planner`;
  }
  drawQueries(el.chartQueries, counts, note, empty);
  const d = app.run.detail;
  const atEnd = app.replay.step >= app.replay.last && app.run.done;
  const end = tree.end ?? (atEnd && d && !LIVE.has(d.status) ? d : null);
  const skeletons = tree.end?.skeleton_s ?? tree.skeletonSeconds;
  drawTime(el.chartTime, {
    topk: skeletons,
    queries: tree.queryWall,
    planning: end?.planning_s ?? tree.solution?.planning_s ?? tree.lastT,
    execution: end?.execution_s ?? tree.solution?.execution_s ?? null,
    live: end === null,
  });
}

// --- the 3D view -------------------------------------------------------------------------------

function setUpViewer(url) {
  if (!url) {
    el.viewerFrame.hidden = true;
    el.viewerFrame.removeAttribute("src");
    el.viewerNote.textContent = "The 3D view is off: this server runs without a viewer (tamp serve --no-viewer).";
    el.viewerNote.hidden = false;
    el.layoutToggle.hidden = true;
    setSideBySide(false, false);
    return;
  }
  const target = new URL(url, location.href);
  if (target.hostname === "0.0.0.0") target.hostname = location.hostname;
  el.viewerFrame.src = target.href;
  el.viewerFrame.hidden = false;
  el.viewerNote.hidden = true;
  el.layoutToggle.hidden = false;
  const saved = localStorage.getItem("tamp.sideBySide");
  setSideBySide(saved === null ? window.innerWidth >= SIDE_BY_SIDE_PX : saved === "1", false);
  scheduleViewer();
}

/** The 3D view beside the tree (or below it); the same iframe either way (CSS grid areas). */
function setSideBySide(on, remember = true) {
  document.body.classList.toggle("side-by-side", on);
  el.layoutToggle.textContent = on ? "3D view below" : "3D view beside the tree";
  el.layoutToggle.setAttribute("aria-pressed", String(on));
  if (remember) localStorage.setItem("tamp.sideBySide", on ? "1" : "0");
  view.requestDraw();
}

el.layoutToggle.addEventListener("click", () => setSideBySide(!document.body.classList.contains("side-by-side")));

let viewerTimer = 0;
let viewerPending = ""; // the body waiting for the debounce
let viewerSent = ""; // the body the viewer was last told

/** What the 3D view should show: the selected run after events 0..step (null: all of it). */
function viewerBody() {
  if (!app.health?.viewer_url || !app.run || app.run.id === null) return null;
  const replay = app.replay;
  const atEnd = app.follow && replay.step >= replay.last; // null: everything, live included
  const step = atEnd || replay.step < 0 ? null : replay.events[replay.step].seq;
  const body = { run_id: app.run.id, step };
  if (app.selectedId !== null && app.replay.tree.byId.has(app.selectedId)) body.node = app.selectedId;
  return body;
}

let pickedTimer = 0;

/**
 * A ghost clicked in the 3D view names its node: the page says which and selects it (tree,
 * inspector, and so the 3D view's highlight). The viewer keeps the last click of the run it
 * shows (GET /api/viewer); the page asks while it shows a run. The first answer after a run is
 * selected only says which clicks were made before: those are not this page's.
 */
async function pollPicked() {
  clearTimeout(pickedTimer);
  if (!app.health?.viewer_url) return;
  const run = app.run;
  if (currentPage === "runs" && run && run.id !== null && !document.hidden) {
    try {
      const shown = await api("/api/viewer");
      const picked = shown.picked;
      if (app.run === run) {
        const mine = picked && picked.run_id === run.id && shown.run_id === run.id;
        const clicks = mine ? picked.count : 0;
        if (run.pickedSeen === undefined) run.pickedSeen = clicks;
        else if (mine && clicks !== run.pickedSeen) {
          run.pickedSeen = clicks;
          showPicked(picked);
        }
      }
    } catch {
      // the next poll tries again
    }
  }
  pickedTimer = setTimeout(pollPicked, PICKED_POLL_MS);
}

function showPicked(picked) {
  el.viewerPicked.innerHTML =
    `3D view: ghost of <b>node #${escapeHtml(picked.node_id)}</b>` +
    (picked.label ? ` · <code>${escapeHtml(picked.label)}</code>` : "") +
    " (selected in the tree)";
  el.viewerPicked.hidden = false;
  if (app.replay.tree.byId.has(picked.node_id)) {
    app.selectedId = picked.node_id;
    renderInspector();
    renderLegend();
    view.requestDraw();
    scheduleViewer(); // the 3D view highlights the page's selection, this one too
  }
}

/**
 * Tell the viewer 200 ms after what it should show last changed. Events streaming in while the
 * page follows a live run do not change it (step stays null), so they do not hold it back.
 */
function scheduleViewer() {
  const body = viewerBody();
  if (body === null) return;
  const key = JSON.stringify(body);
  if (key === viewerPending || (viewerPending === "" && key === viewerSent)) return;
  clearTimeout(viewerTimer);
  viewerPending = key;
  viewerTimer = setTimeout(() => {
    viewerPending = "";
    sendViewer(body, key);
  }, VIEWER_DEBOUNCE_MS);
}

async function sendViewer(body, key) {
  if (key === viewerSent) return;
  viewerSent = key;
  try {
    await api("/api/viewer", { method: "PUT", body });
  } catch (err) {
    viewerSent = "";
    console.warn("3D view not updated:", err.message);
  }
}

// --- the test hook -----------------------------------------------------------------------------

function drawNow() {
  view.draw();
}

window.dashboard = {
  /** Replace the current run's events with ``events``; returns the ms to fold and draw. */
  loadEvents(events) {
    const t0 = performance.now();
    const state = newRunState(null);
    state.done = true;
    state.caughtUp = true;
    resetRunView(state);
    app.replay.load(events);
    view.setTree(app.replay.tree);
    app.replay.goTo(app.replay.last);
    app.follow = true;
    drawNow();
    updateStep();
    renderHeader();
    return performance.now() - t0;
  },
  /** Go to step k (state after events 0..k); returns the ms to fold and draw. */
  step(k) {
    const t0 = performance.now();
    app.replay.goTo(k);
    app.follow = app.replay.step >= app.replay.last;
    drawNow();
    updateStep();
    return performance.now() - t0;
  },
  state() {
    const replay = app.replay;
    const tree = replay.tree;
    return {
      step: replay.step,
      last: replay.last,
      nodes: tree.nodeCount,
      failed: tree.failed,
      selected: app.selectedId,
      runId: app.run?.id ?? null,
      live: isLive(),
      done: app.run?.done ?? false,
      loading: app.run?.loading ?? null,
      follow: app.follow,
      playing: app.playing,
      solution: tree.solution?.node_id ?? null,
      queries: tree.sampled,
      reused: tree.reused,
      skeletons: tree.planList.length,
      progress: tree.progress?.message ?? null,
      fans: tree.fans.length,
      matches: app.search.matches.length,
      // the page has asked the 3D view once for this run: a ghost clicked from now on is shown
      pickedReady: app.run?.pickedSeen !== undefined,
    };
  },
  /** Where node ``id`` is drawn, in page (client) pixels, or null. */
  nodePosition(id) {
    const p = view.position(id);
    if (p === null) return null;
    const rect = el.canvas.getBoundingClientRect();
    return { x: rect.left + p.x, y: rect.top + p.y };
  },
  /** Where the fan of node ``id``'s folded failed leaves is drawn (client px), or null. */
  fanPosition(id) {
    const p = view.fanPosition(id);
    if (p === null) return null;
    const rect = el.canvas.getBoundingClientRect();
    return { x: rect.left + p.x, y: rect.top + p.y };
  },
  /** Ids of the nodes at the current step, in the order they were added. */
  nodeIds() {
    const tree = app.replay.tree;
    return tree.order.filter((n) => !(n.implicit && tree.nodeCount === 0)).map((n) => n.id);
  },
  /** The row labels drawn in the gutter: [{level, text}]. */
  rows: () => (view.rowsDrawn ?? []).map(({ level, text, name, count }) => ({ level, text, name, count })),
  select(id) {
    app.selectedId = id;
    renderInspector();
    renderLegend();
    view.requestDraw();
  },
  fit() {
    view.fit();
  },
  selectRun,
  page: () => currentPage,
  compare: () => compareView.state(),
  /** Where the benchmark scatter draws seed ``seed`` (client px), or null. */
  scatterPoint: (seed) => benchPage.pointPosition(seed),
  benchMs: () => benchPage.ms,
  /** What the 3D view was last told (a PUT /api/viewer body, or null) and whether a newer
   * body waits for the debounce. */
  viewerSync: () => ({ pending: viewerPending !== "", sent: viewerSent === "" ? null : JSON.parse(viewerSent) }),
  showPicked,
  /** When each part of opening the run was done (ms since the page's start): selected,
   * detail (GET /api/runs/{id}), read (every stored event), folded, drawn. */
  timings: () => ({ ...(app.run?.marks ?? {}) }),
  /** Search the tree as the search box does (and show the first match); the matches' ids. */
  search(text) {
    el.searchInput.value = text;
    runSearch(text);
    return app.search.matches.slice();
  },
  /** The colour of Q ``q`` on the scale drawn now ([r, g, b]), or null (grey). */
  colourOf(q) {
    const range = view.scaleOf(app.replay.tree);
    if (range === null || q === null) return null;
    return qRgbAt(range.hi > range.lo ? (q - range.lo) / (range.hi - range.lo) : 0);
  },
};

// --- pages: the hash says which (#run=ID, #compare=A,B, #benchmarks, #bench=ID, #models, #model=N)

const compareView = new CompareView();
const benchPage = new BenchPage({
  openTraining: (benchId, planner) => {
    modelsPage.prefill(benchId, planner);
    location.hash = "#models";
  },
});
const modelsPage = new ModelsPage({ onModels: setModels });
let currentPage = "runs";

function showPage(name) {
  currentPage = name;
  const nav = name === "compare" ? "runs" : name;
  for (const node of el.pages) {
    if (node.tagName === "A") node.classList.toggle("active", node.dataset.page === nav);
    else node.hidden = node.dataset.page !== name;
  }
  document.body.dataset.page = name;
}

function route() {
  const params = new URLSearchParams(location.hash.slice(1));
  const [key] = [...params.keys()];
  const arg = key === undefined ? null : params.get(key);
  const page = { compare: "compare", benchmarks: "benchmarks", bench: "benchmarks", models: "models", model: "models" }[key] ?? "runs";
  showPage(page);
  benchPage.show(page === "benchmarks", key === "bench" ? arg : null);
  modelsPage.show(page === "models", key === "model" ? arg : null);
  if (page === "compare") {
    const [a, b] = (arg ?? "").split(",");
    if (a && b) compareView.show(a, b);
    return;
  }
  if (page === "runs") {
    view.requestDraw();
    scheduleCharts();
    if (key === "run" && arg && app.run?.id !== arg) selectRun(arg);
    else if (key === "run" && arg) renderHeader();
  }
}

// --- start ---------------------------------------------------------------------------------------

loadForm();
loadReports();
updateStep();
drawCharts();
/** Show the page the address names; the pages of charts (compare, benchmarks, models) once
 * plotly has loaded, a run at once (its charts are drawn again when plotly is there). */
function go() {
  if (/^#?(run=|$)/.test(location.hash)) route();
  else {
    loadPlotly();
    window.plotlyReady.then(route);
  }
}

/** Load plotly (once): the pages of charts ask at once, the run page once its run is drawn
 * (its 3.5 MB took the page's thread while a big run's events were read and folded). */
function loadPlotly() {
  if (plotlyAsked) return;
  plotlyAsked = true;
  const script = document.createElement("script");
  script.src = "/vendor/plotly.min.js";
  script.onload = () => window.plotlyLoaded();
  script.onerror = () => {
    window.plotlyFailed = true;
    window.plotlyLoaded();
  };
  document.head.append(script);
}

go(); // a run in the address is opened at once, beside the list's first read
window.addEventListener("hashchange", go);
window.plotlyReady.then(() => {
  if (currentPage === "runs") drawCharts();
});
setTimeout(loadPlotly, 5000); // in any case, soon
refresh().then(() => pollPicked());
