// The dashboard page: launch runs, list them, replay and watch one run's search; and, on pages
// of their own (the hash says which), two runs compared (compare.js), benchmarks
// (benchmarks.js) and models with their training (models.js).
//
// It talks only to the REST API and the websocket of docs/dashboard.md. The selected run's
// events are kept in a Replay (tree.js); the step slider moves its cursor, a live run appends
// to it, and the canvas (treeview.js) redraws at the next animation frame.

import { ApiError, api, streamUrl } from "./api.js";
import { BenchPage } from "./benchmarks.js";
import { clearChart, drawQueries, drawTime } from "./charts.js";
import { CompareView } from "./compare.js";
import { escapeHtml, num, seconds, value, when } from "./format.js";
import { ModelsPage } from "./models.js";
import { Replay } from "./tree.js";
import { TreeView, shortLabel } from "./treeview.js";

const LIVE = new Set(["queued", "running"]);
const POLL_LIVE_MS = 1500; // runs list refresh while some run is queued or running
const POLL_IDLE_MS = 8000; // otherwise
const VIEWER_DEBOUNCE_MS = 200;
const PICKED_POLL_MS = 1500; // how often the page asks which ghost was clicked in the 3D view
const CHART_DELAY_MS = 250; // charts follow the step at most this often
const RECONNECT_MS = [1000, 2000, 5000, 10000]; // waits before reconnecting a dropped stream
const PAGE = 50; // runs per page of the list
const PLAY_ICON = '<svg viewBox="0 0 16 16" aria-hidden="true"><path d="M4 2.5v11l9-5.5z"/></svg>';
const PAUSE_ICON = '<svg viewBox="0 0 16 16" aria-hidden="true"><path d="M4 3h3v10H4zM9 3h3v10H9z"/></svg>';

const $ = (id) => document.getElementById(id);

const el = {
  health: $("health"),
  form: $("launch-form"),
  scene: $("launch-scene"),
  sceneDescription: $("scene-description"),
  planner: $("launch-planner"),
  seed: $("launch-seed"),
  budget: $("launch-budget"),
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
  tooltip: $("tree-tooltip"),
  nodeCount: $("node-count"),
  fit: $("btn-fit"),
  qLegend: $("q-legend"),
  qLo: $("q-lo"),
  qHi: $("q-hi"),
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
  pages: document.querySelectorAll("[data-page]"),
};

const app = {
  health: null,
  scenes: [],
  models: [],
  runs: [],
  limit: PAGE,
  replay: new Replay(),
  run: null, // {id, detail, ws, done, token} of the selected run; id null for loaded events
  follow: true, // the cursor stays on the newest event as events arrive
  playing: false,
  selectedId: null,
  pending: [], // events received and not yet appended
  flushQueued: false,
};

const view = new TreeView(el.canvas, {
  onSelect: (node) => {
    app.selectedId = node ? node.id : null;
    renderInspector();
    scheduleViewer();
  },
  onHover: showTooltip,
});
view.setTree(app.replay.tree);

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
      const figures = [
        `seed ${escapeHtml(r.seed)}`,
        r.planning_s !== null && r.planning_s !== undefined ? `plan ${seconds(r.planning_s)}` : "",
        r.execution_s !== null && r.execution_s !== undefined ? `exec ${seconds(r.execution_s)}` : "",
        `${r.queries ?? 0} queries`,
      ].filter(Boolean);
      const current = app.run && app.run.id === r.id;
      return `<li data-testid="run-row" data-run-id="${escapeHtml(r.id)}" data-status="${escapeHtml(r.status)}"
                 class="run-row${current ? " selected" : ""}" tabindex="0" role="button"
                 ${current ? 'aria-current="true"' : ""}>
        <div class="run-line">
          <span class="badge ${escapeHtml(r.status)}" data-testid="run-status">${escapeHtml(r.status)}</span>
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

// --- the selected run and its event stream ---------------------------------------------------

let token = 0;

async function selectRun(id, run = null) {
  closeStream();
  stopPlay();
  const mine = ++token;
  app.run = { id, detail: run, ws: null, done: false, token: mine, caughtUp: false, retries: 0 };
  app.replay.load([]);
  app.pending = [];
  app.follow = true;
  app.selectedId = null;
  view.setTree(app.replay.tree);
  history.replaceState(null, "", `#run=${encodeURIComponent(id)}`);
  for (const row of el.runs.querySelectorAll("[data-run-id]")) {
    const on = row.dataset.runId === id;
    row.classList.toggle("selected", on);
    if (on) row.setAttribute("aria-current", "true");
    else row.removeAttribute("aria-current");
  }
  renderHeader();
  updateStep();
  scheduleViewer();
  openStream(mine, -1);
  try {
    const detail = await api(`/api/runs/${encodeURIComponent(id)}`);
    if (app.run && app.run.token === mine) {
      app.run.detail = detail;
      renderHeader();
      scheduleCharts();
    }
  } catch (err) {
    if (app.run && app.run.token === mine) {
      el.header.innerHTML = `<span class="error-text">Run ${escapeHtml(id)}: ${escapeHtml(err.message)}</span>`;
      if (err.status === 404) {
        closeStream(); // no such run: nothing will ever come
        updateStep();
      }
    }
  }
}

function openStream(mine, after) {
  const ws = new WebSocket(streamUrl(app.run.id, after));
  app.run.ws = ws;
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
        openStream(mine, app.replay.events.length ? app.replay.events.at(-1).seq : -1);
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

function isLive() {
  return app.run !== null && app.run.id !== null && !app.run.done;
}

function renderHeader() {
  const run = app.run;
  if (run === null) return;
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
  const figures = [
    `planning <b>${seconds(d.planning_s)}</b>`,
    `execution <b>${seconds(d.execution_s)}</b>`,
    `<b>${d.queries ?? 0}</b> queries`,
  ];
  if (d.oracle_s !== null && d.oracle_s !== undefined) figures.push(`oracle ${seconds(d.oracle_s)}`);
  const message = d.message
    ? `<span class="muted run-message" title="${escapeHtml(d.message)}">${escapeHtml(d.message)}</span>`
    : "";
  const cancel = LIVE.has(d.status)
    ? `<button type="button" id="btn-cancel" data-testid="btn-cancel" class="danger">Cancel</button>`
    : "";
  el.header.innerHTML = `
    <span class="run-name" title="${escapeHtml(d.id)}">Run ${escapeHtml(d.id.slice(0, 8))}</span>
    <span>${escapeHtml(d.scene)} · ${escapeHtml(d.planner)} · seed ${escapeHtml(d.seed)}${d.config?.model_name ? ` · model <a href="#model=${encodeURIComponent(d.config.model_name)}" data-testid="run-model">${escapeHtml(d.config.model_name)}</a>` : ""}</span>
    <span class="badge ${escapeHtml(d.status)}" data-testid="run-status">${escapeHtml(d.status)}</span>
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

/** "Compare with": the other runs of the list, the same scene first. */
function compareControl(d) {
  const others = app.runs.filter((r) => r.id !== d.id);
  if (others.length === 0) return "";
  others.sort((x, y) => (y.scene === d.scene) - (x.scene === d.scene));
  const options = others
    .map(
      (r) =>
        `<option value="${escapeHtml(r.id)}">${escapeHtml(r.scene)} · ${escapeHtml(r.planner)} · seed ${escapeHtml(r.seed)} · ${escapeHtml(r.id.slice(0, 8))}</option>`,
    )
    .join("");
  return `<span class="compare-with"><select id="compare-with" data-testid="compare-with" aria-label="run to compare with">${options}</select>
    <button type="button" id="btn-compare" data-testid="btn-compare">Compare</button></span>`;
}

function bindCompare(d) {
  const button = $("btn-compare");
  if (!button) return;
  button.addEventListener("click", () => {
    const other = $("compare-with").value;
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
  const live = isLive();
  el.liveBadge.hidden = !live;
  el.liveBadge.textContent = app.follow ? "● live" : "● live run (last event button follows it)";
  el.liveBadge.classList.toggle("paused", !app.follow);
  const n = tree.nodeCount;
  const failed = tree.failed ? ` · ${tree.failed.toLocaleString()} failed` : "";
  el.nodeCount.textContent = `${n.toLocaleString()} node${n === 1 ? "" : "s"}${failed}`;
  el.nodeCount.dataset.nodes = String(n);
  el.stepEvent.textContent = step >= 0 ? describe(replay.events[step]) : "";
  renderEmpty();
  renderLegend();
  if (app.selectedId !== null) renderInspector();
  scheduleCharts();
  scheduleViewer();
}

function renderEmpty() {
  const tree = app.replay.tree;
  let text = "";
  if (app.run === null) text = "No run selected.";
  else if (tree.nodeCount === 0) {
    const planner = app.run.detail?.planner ?? tree.run?.planner;
    if (planner === "sequential") {
      text = "The sequential planner binds skeletons in order and builds no search tree; see the charts below.";
    } else if (app.replay.last < 0) {
      text = isLive() ? "Waiting for the run's first events…" : "This run has no events.";
    } else if (tree.end !== null && app.replay.step === app.replay.last) {
      text = "This run ended without a search tree.";
    } else {
      text = "No tree yet at this step (abstract planning comes first).";
    }
  }
  el.treeEmpty.textContent = text;
  el.treeEmpty.hidden = text === "";
}

function renderLegend() {
  // The Q range is known after a draw; legend follows on the next frame.
  requestAnimationFrame(() => {
    const range = view.qRange;
    el.qLegend.hidden = range === null;
    if (range) {
      el.qLo.textContent = seconds(range.lo);
      el.qHi.textContent = seconds(range.hi);
    }
  });
}

function describe(ev) {
  const t = `t=${num(ev.t, 2)} s · #${ev.seq} `;
  switch (ev.type) {
    case "run_started":
      return `${t}run started: ${ev.scene}, ${ev.planner}, seed ${ev.seed}`;
    case "abstract_plans_found":
      return `${t}${ev.plans.length} abstract plans in ${seconds(ev.seconds)}`;
    case "node_added":
      return `${t}node ${ev.node_id} added: ${ev.label}`;
    case "stream_queried":
      return (
        `${t}query ${ev.stream}(${ev.input_names.join(" ")}) ${ev.success ? "ok" : "FAILED"} ` +
        (ev.reused_from !== null && ev.reused_from !== undefined
          ? `reused from node ${ev.reused_from}`
          : `in ${seconds(ev.wall_s)}`) +
        ` → node ${ev.node_id}${ev.error ? `: ${ev.error}` : ev.reason ? `: ${ev.reason}` : ""}`
      );
    case "model_prediction":
      return `${t}prediction for node ${ev.node_id}: Q ${num(ev.q)} s, P_S ${num(ev.p_s)}`;
    case "node_visited":
      return `${t}back-up node ${ev.node_id}: ${ev.visits} visits, value ${num(ev.value)}`;
    case "solution_found":
      return (
        `${t}solution at node ${ev.node_id} (plan ${ev.plan_index}): ` +
        `planning ${seconds(ev.planning_s)}, execution ${seconds(ev.execution_s)}`
      );
    case "run_finished":
      return `${t}run finished: ${ev.status} (${ev.message})`;
    case "run_failed":
      return `${t}run failed: ${ev.error}`;
    case "run_cancelled":
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
  const p = node.pred;
  const noModels =
    tree.run && !usesModel(tree.run.planner)
      ? ` (the ${escapeHtml(tree.run.planner)} planner has no models)`
      : "";
  html += p
    ? `<table class="pred" data-testid="inspector-prediction">
        <caption>Model prediction (next query)</caption>
        <tr><th title="success probability">P<sub>S</sub></th><td>${num(p.p_s)}</td>
            <th title="seconds of a successful query">R<sub>S</sub></th><td>${seconds(p.r_s)}</td></tr>
        <tr><th title="seconds of a failed query">R<sub>F</sub></th><td>${seconds(p.r_f)}</td>
            <th title="seconds to execute the trajectory">R<sub>M</sub></th><td>${seconds(p.r_m)}</td></tr>
        <tr><th title="expected seconds still to spend: execution of the trajectories bound so far + Eq. 4 for the rest">Q</th><td colspan="3"><b>${seconds(p.q)}</b></td></tr>
      </table>`
    : `<p class="muted" data-testid="inspector-prediction">No model prediction${noModels}.</p>`;
  const plan = tree.plans?.plans?.find((pl) => pl.index === node.planIndex);
  if (plan && !isRoot) {
    const streams = plan.streams
      .map((s, i) => `<li class="${i + 1 === node.depth ? "here" : ""}">${escapeHtml(s)}</li>`)
      .join("");
    const actions = plan.actions.map((a) => `<li>${escapeHtml(a)}</li>`).join("");
    const summary =
      `Stream plan ${plan.index}: ${plan.streams.length} streams, ` +
      `${plan.actions.length} actions (cost ${num(plan.cost)})`;
    html += `<details class="plan"${isPlan ? " open" : ""}><summary>${summary}</summary>
      <ol>${streams}</ol><p class="muted">actions</p><ol>${actions}</ol></details>`;
  }
  if (!isRoot && !isPlan) {
    const raw = JSON.stringify({ inputs: query?.inputs ?? null, outputs: node.outputs }, null, 1);
    const shown = raw.length > 20000 ? `${raw.slice(0, 20000)}\n…` : raw;
    html += `<details class="raw"><summary>Raw values</summary><pre>${escapeHtml(shown)}</pre></details>`;
  }
  el.inspectorBody.innerHTML = html;
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

function showTooltip(node, e) {
  if (!node || !e) {
    el.tooltip.hidden = true;
    return;
  }
  const rect = el.canvas.getBoundingClientRect();
  const q = node.pred ? ` · Q ${seconds(node.pred.q)}` : "";
  const fail = node.parent !== null && node.stream !== null && !node.success ? " · failed" : "";
  el.tooltip.textContent = `#${node.id} ${node.label || shortLabel(node)}${fail}${q}`;
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
  drawTime(el.chartTime, {
    topk: tree.plans?.seconds ?? 0,
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
    return;
  }
  const target = new URL(url, location.href);
  if (target.hostname === "0.0.0.0") target.hostname = location.hostname;
  el.viewerFrame.src = target.href;
  el.viewerFrame.hidden = false;
  el.viewerNote.hidden = true;
  scheduleViewer();
}

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

let pickedCount = 0; // the ghost clicks already shown
let pickedTimer = 0;

/**
 * A ghost clicked in the 3D view names its node: the page says which and selects it (tree,
 * inspector, and so the 3D view's highlight). The viewer keeps the last click (GET /api/viewer);
 * the page asks while it shows a run.
 */
async function pollPicked() {
  clearTimeout(pickedTimer);
  if (!app.health?.viewer_url) return;
  if (currentPage === "runs" && app.run && app.run.id !== null && !document.hidden) {
    try {
      const shown = await api("/api/viewer");
      const picked = shown.picked;
      if (picked && picked.count !== pickedCount && shown.run_id === app.run.id) {
        pickedCount = picked.count;
        showPicked(picked);
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
    closeStream();
    stopPlay();
    ++token;
    app.run = { id: null, detail: null, ws: null, done: true, token, caughtUp: true };
    app.replay.load(events);
    app.selectedId = null;
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
    return {
      step: replay.step,
      last: replay.last,
      nodes: replay.tree.nodeCount,
      failed: replay.tree.failed,
      selected: app.selectedId,
      runId: app.run?.id ?? null,
      live: isLive(),
      follow: app.follow,
      playing: app.playing,
      solution: replay.tree.solution?.node_id ?? null,
    };
  },
  /** Where node ``id`` is drawn, in page (client) pixels, or null. */
  nodePosition(id) {
    const p = view.position(id);
    if (p === null) return null;
    const rect = el.canvas.getBoundingClientRect();
    return { x: rect.left + p.x, y: rect.top + p.y };
  },
  /** Ids of the nodes at the current step, in the order they were added. */
  nodeIds() {
    const tree = app.replay.tree;
    return tree.order.filter((n) => !(n.implicit && tree.nodeCount === 0)).map((n) => n.id);
  },
  select(id) {
    app.selectedId = id;
    renderInspector();
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
refresh().then(() => {
  route();
  window.addEventListener("hashchange", route);
  pollPicked();
});
