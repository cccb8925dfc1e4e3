// The models page (#models, #model=NAME): every model offered with its domain and where it came
// from; one model's training runs and seeds, its per-stream validation (AUC of P_S, log loss
// and cost errors against the prior's) and a calibration plot; a form that trains a new model
// from stored runs (a background job: POST /api/training, the code of `tamp train`), and a
// button that launches a learned run with a model.

import { LIVE_STATUSES, RUN_STATUSES, STATUS } from "/generated/definitions.js";
import { ApiError, api } from "./api.js";
import { escapeHtml, num, seconds, when } from "./format.js";

const POLL_JOB_MS = 700;
const CONFIG = { displayModeBar: false, responsive: true };
const FONT = { family: "system-ui, -apple-system, Segoe UI, sans-serif", size: 12, color: "#1f2937" };
const FINISHED = new Set(RUN_STATUSES.filter((s) => !LIVE_STATUSES.includes(s)));

const $ = (id) => document.getElementById(id);

function pct(x) {
  return x === null || x === undefined ? "–" : `${(100 * x).toFixed(1)}%`;
}

export class ModelsPage {
  /** ``onModels(models)`` tells the rest of the page the models offered changed. */
  constructor({ onModels }) {
    this.el = {
      list: $("model-list"),
      detail: $("model-detail"),
      form: $("train-form"),
      name: $("train-name"),
      bench: $("train-bench"),
      runs: $("train-runs"),
      seed: $("train-seed"),
      epochs: $("train-epochs"),
      error: $("train-error"),
      job: $("train-job"),
    };
    this.onModels = onModels;
    this.models = [];
    this.scenes = [];
    this.current = null;
    this.visible = false;
    this.jobTimer = 0;
    this.wantBench = null; // "benchId|planner" to preselect once the choices are loaded
    this.benchRuns = new Map(); // "benchId|planner" -> run ids
    this.el.form.addEventListener("submit", (e) => {
      e.preventDefault();
      this._train();
    });
    this.el.bench.addEventListener("change", () =>
      this._syncRuns().catch((err) => this._error(`Cannot read the benchmark's runs: ${err.message}`)),
    );
    this.el.list.addEventListener("click", (e) => {
      const row = e.target.closest("[data-model]");
      if (row) location.hash = `#model=${encodeURIComponent(row.dataset.model)}`;
    });
  }

  setScenes(scenes) {
    this.scenes = scenes;
  }

  setModels(models) {
    this.models = models;
    this._renderList();
  }

  /** Preselect the runs of planner ``planner`` in benchmark ``benchId`` in the train form. */
  prefill(benchId, planner) {
    this.wantBench = `${benchId}|${planner}`;
  }

  async show(visible, name = null) {
    this.visible = visible;
    if (!visible) return;
    this.current = name;
    this._renderList();
    this._loadChoices();
    this._resumeJob();
    if (name) await this._detail(name);
    else this.el.detail.innerHTML = `<section class="card"><p class="muted">Select a model on the left, or train one.</p></section>`;
  }

  async reloadModels() {
    try {
      const models = await api("/api/models");
      this.setModels(models);
      this.onModels(models);
    } catch (err) {
      console.warn("models not reloaded:", err.message);
    }
  }

  _renderList() {
    if (this.models.length === 0) {
      this.el.list.innerHTML = `<li class="muted empty">No models: train one below.</li>`;
      return;
    }
    this.el.list.innerHTML = this.models
      .map(
        (m) => `<li data-model="${escapeHtml(m.name)}" data-testid="model-row" tabindex="0" role="button"
            class="run-row${m.name === this.current ? " selected" : ""}">
          <div class="run-line"><span class="run-title">${escapeHtml(m.name)}</span>
            <span class="badge">${escapeHtml(m.source)}</span>${m.default ? ` <span class="muted">default</span>` : ""}</div>
          <div class="run-figures">${escapeHtml(m.domain)} · ${m.streams.length} streams${m.runs ? ` · ${m.runs} runs` : ""}${m.validated ? " · validated" : ""}</div>
        </li>`,
      )
      .join("");
  }

  async _loadChoices() {
    try {
      const [benches, page] = await Promise.all([api("/api/benchmarks"), api("/api/runs?limit=200&offset=0")]);
      const options = [`<option value="">none: the runs selected below</option>`];
      for (const b of benches) {
        for (const p of b.planners) {
          const n = b.progress[p]?.done ?? 0;
          if (n === 0) continue;
          options.push(
            `<option value="${escapeHtml(`${b.id}|${p}`)}">${escapeHtml(b.scene)} · ${escapeHtml(p)} runs (${n}) of benchmark ${escapeHtml(b.id.slice(0, 8))}</option>`,
          );
        }
      }
      const keep = this.wantBench ?? this.el.bench.value;
      this.el.bench.innerHTML = options.join("");
      if ([...this.el.bench.options].some((o) => o.value === keep)) this.el.bench.value = keep;
      this.wantBench = null;
      const chosen = new Set([...this.el.runs.selectedOptions].map((o) => o.value));
      this.el.runs.innerHTML = page.runs
        .filter((r) => FINISHED.has(r.status))
        .map(
          (r) => `<option value="${escapeHtml(r.id)}" ${chosen.has(r.id) ? "selected" : ""}>${escapeHtml(r.scene)} · ${escapeHtml(r.planner)} · seed ${escapeHtml(r.seed)} · ${r.queries ?? 0} queries · ${escapeHtml(r.status)}</option>`,
        )
        .join("");
      await this._syncRuns();
    } catch (err) {
      this._error(`Cannot load the runs to train on: ${err.message}`);
    }
  }

  /** With a benchmark chosen, its planner's runs are the ones trained on. */
  async _syncRuns() {
    const key = this.el.bench.value;
    this.el.runs.disabled = key !== "";
    if (key === "" || this.benchRuns.has(key)) return;
    const [benchId, planner] = key.split("|");
    const info = await api(`/api/benchmarks/${encodeURIComponent(benchId)}`);
    const ids = info.summary.trials.map((row) => row[planner]?.run_id).filter(Boolean);
    this.benchRuns.set(key, ids);
    if (!this.el.name.value) this.el.name.value = `${info.scene}-${planner}-${benchId.slice(0, 6)}`.replace(/[^A-Za-z0-9_.-]/g, "-");
  }

  _error(text) {
    this.el.error.textContent = text;
    this.el.error.hidden = text === "";
  }

  async _train() {
    this._error("");
    const key = this.el.bench.value;
    let runs;
    let benchmark = null;
    if (key) {
      await this._syncRuns();
      runs = this.benchRuns.get(key) ?? [];
      benchmark = key.split("|")[0];
    } else {
      runs = [...this.el.runs.selectedOptions].map((o) => o.value);
    }
    const body = {
      name: this.el.name.value.trim(),
      runs,
      seed: this.el.seed.value === "" ? 0 : Number(this.el.seed.value),
      epochs: this.el.epochs.value === "" ? 300 : Number(this.el.epochs.value),
    };
    if (benchmark) body.benchmark = benchmark;
    const submit = this.el.form.querySelector("button[type=submit]");
    submit.disabled = true;
    try {
      const job = await api("/api/training", { method: "POST", body });
      this._showJob(job);
    } catch (err) {
      this._error(err instanceof ApiError ? err.message : String(err));
    } finally {
      submit.disabled = false;
    }
  }

  async _resumeJob() {
    try {
      const jobs = await api("/api/training");
      const running = jobs.find((j) => j.status === STATUS.RUNNING);
      if (running) this._showJob(running);
    } catch {
      // no training route: no job to show
    }
  }

  _showJob(job) {
    clearTimeout(this.jobTimer);
    const box = this.el.job;
    box.hidden = false;
    box.dataset.status = job.status;
    const stream = job.stream ? ` · fitting <code>${escapeHtml(job.stream)}</code>` : "";
    const done =
      job.status === STATUS.DONE
        ? ` <a href="#model=${encodeURIComponent(job.name)}" data-testid="train-open">open ${escapeHtml(job.name)}</a>`
        : "";
    box.innerHTML = `<div><b>${escapeHtml(job.name)}</b> · ${escapeHtml(job.domain)} · ${job.runs.length} runs, ${job.queries} queries
        <span class="badge ${job.status === STATUS.DONE ? "solved" : job.status === STATUS.FAILED ? "failed" : "running"}" data-testid="train-status">${escapeHtml(job.status)}</span></div>
      <progress data-testid="train-progress" max="1" value="${job.progress}"></progress> ${pct(job.progress)}${stream}${done}
      ${job.message ? `<p class="muted">${escapeHtml(job.message)}</p>` : ""}`;
    if (job.status === STATUS.RUNNING) {
      this.jobTimer = setTimeout(async () => {
        try {
          this._showJob(await api(`/api/training/${encodeURIComponent(job.id)}`));
        } catch (err) {
          this._error(err.message);
        }
      }, POLL_JOB_MS);
    } else if (job.status === STATUS.DONE) {
      this.reloadModels().then(() => {
        if (this.visible) location.hash = `#model=${encodeURIComponent(job.name)}`;
      });
    }
  }

  async _detail(name) {
    let m;
    try {
      m = await api(`/api/models/${encodeURIComponent(name)}`);
    } catch (err) {
      this.el.detail.innerHTML = `<section class="card"><p class="error-text" data-testid="model-error">Model ${escapeHtml(name)}: ${escapeHtml(err.message)}</p></section>`;
      return;
    }
    if (name !== this.current) return;
    const meta = m.metadata ?? {};
    const prov = meta.provenance ?? {};
    const seeds = Object.entries(meta.training_seeds ?? {})
      .map(([scene, list]) => `<li><code>${escapeHtml(scene)}</code>: ${list.length} seeds (${escapeHtml(seedRanges(list))})</li>`)
      .join("");
    const runs = (prov.runs ?? [])
      .map((id) => `<a href="#run=${encodeURIComponent(id)}">${escapeHtml(id.slice(0, 8))}</a>`)
      .join(" ");
    // The scenes of its domain, the ones it was trained on first.
    const trainedOn = Object.keys(meta.training_seeds ?? {});
    const scenes = this.scenes
      .filter((s) => s.domain === m.domain)
      .sort((x, y) => trainedOn.includes(y.name) - trainedOn.includes(x.name));
    const launch = scenes.length
      ? `<form class="inline-form" id="model-launch" data-testid="model-launch">
          <label>Scene <select name="scene" data-testid="model-launch-scene">${scenes.map((s) => `<option>${escapeHtml(s.name)}</option>`).join("")}</select></label>
          <label>Seed <input name="seed" type="number" step="1" value="0" /></label>
          <label>Planner <select name="planner"><option>learned</option><option>paper</option></select></label>
          <button type="submit" class="primary" data-testid="model-launch-submit">Launch a run with ${escapeHtml(m.name)}</button>
          <span class="error" role="alert" hidden></span>
        </form>`
      : `<p class="muted">No scene of the ${escapeHtml(m.domain)} domain is offered here.</p>`;
    const v = meta.validation;
    this.el.detail.innerHTML = `
      <section class="card" data-testid="model-head">
        <div class="run-header"><span class="run-name">${escapeHtml(m.name)}</span>
          <span>${escapeHtml(m.domain)} domain · ${escapeHtml(m.source)} · ${Math.round(m.bytes / 1024)} kB${m.trained_at ? ` · trained ${escapeHtml(when(m.trained_at))}` : ""}</span></div>
        ${launch}
        <h2>Trained on</h2>
        <ul data-testid="model-seeds">${seeds || `<li class="muted">The file does not say.</li>`}</ul>
        ${runs ? `<p data-testid="model-runs">${prov.runs.length} stored runs: ${runs}</p>` : ""}
        ${prov.benchmark ? `<p>From benchmark <a href="#bench=${encodeURIComponent(prov.benchmark)}">${escapeHtml(prov.benchmark.slice(0, 8))}</a></p>` : ""}
        ${prov.trained_by ? `<p class="muted">Trained by ${escapeHtml(prov.trained_by)}${prov.job ? ` (job ${escapeHtml(prov.job.slice(0, 8))})` : ""}</p>` : ""}
      </section>
      <section class="card">
        <h2>Validation <span class="muted">${v ? `(${v.train_runs.length} training runs, ${v.val_runs.length} held out; seed ${v.seed}, ${v.epochs} epochs)` : ""}</span></h2>
        ${v ? `<table class="grid" data-testid="model-validation">${validationTable(v)}</table>
               <div id="model-calibration" data-testid="model-calibration" class="chart"></div>`
            : `<p class="muted" data-testid="model-validation">This file holds no validation figures (trained before they were kept).</p>`}
      </section>`;
    if (v) calibrationPlot($("model-calibration"), v);
    const form = $("model-launch");
    form?.addEventListener("submit", async (e) => {
      e.preventDefault();
      const error = form.querySelector(".error");
      error.hidden = true;
      const data = new FormData(form);
      const body = { scene: data.get("scene"), planner: data.get("planner"), seed: Number(data.get("seed") || 0), model: m.name };
      try {
        const run = await api("/api/runs", { method: "POST", body });
        location.hash = `#run=${encodeURIComponent(run.id)}`;
      } catch (err) {
        error.textContent = err.message;
        error.hidden = false;
      }
    });
  }
}

function seedRanges(list) {
  const sorted = [...list].sort((a, b) => a - b);
  const parts = [];
  let start = sorted[0];
  let prev = sorted[0];
  for (const s of [...sorted.slice(1), null]) {
    if (s !== null && s === prev + 1) {
      prev = s;
      continue;
    }
    parts.push(start === prev ? `${start}` : `${start}–${prev}`);
    start = s;
    prev = s;
  }
  return sorted.length ? parts.join(", ") : "";
}

function validationTable(v) {
  const pair = (model, prior, f = seconds) => `${f(model)} <span class="muted">(${f(prior)})</span>`;
  const rows = v.streams.map(
    (s) => `<tr data-stream="${escapeHtml(s.stream)}"><td><code>${escapeHtml(s.stream)}</code>${s.prior_used ? ` <span class="muted">prior</span>` : ""}</td>
      <td class="num">${s.n_train}</td><td class="num">${s.n_val}</td><td class="num">${pct(s.success_rate)}</td>
      <td class="num" data-testid="auc">${num(s.auc, 3)}</td>
      <td class="num">${pair(s.log_loss, s.prior_log_loss, (x) => num(x, 3))}</td>
      <td class="num">${pair(s.mae_r_s, s.prior_mae_r_s)}</td><td class="num">${pair(s.mae_r_f, s.prior_mae_r_f)}</td>
      <td class="num">${pair(s.mae_r_m, s.prior_mae_r_m)}</td></tr>`,
  );
  return `<tr><th>stream</th><th>train</th><th>val</th><th>ok</th><th title="area under the ROC curve of P_S on the held-out runs">AUC of P<sub>S</sub></th>
    <th>log loss (prior)</th><th>|err| R<sub>S</sub> (prior)</th><th>|err| R<sub>F</sub> (prior)</th><th>|err| R<sub>M</sub> (prior)</th></tr>${rows.join("")}`;
}

function calibrationPlot(box, v) {
  if (!window.Plotly) return;
  const traces = v.streams
    .filter((s) => s.calibration.length)
    .map((s) => ({
      type: "scatter",
      mode: "lines+markers",
      name: s.stream,
      x: s.calibration.map((b) => b.predicted),
      y: s.calibration.map((b) => b.observed),
      text: s.calibration.map((b) => `${b.n} queries`),
      marker: { size: s.calibration.map((b) => 5 + Math.min(12, Math.sqrt(b.n))) },
      hovertemplate: `${escapeHtml(s.stream)}: predicted %{x:.2f}, observed %{y:.2f} (%{text})<extra></extra>`,
    }));
  window.Plotly.react(
    box,
    traces,
    {
      title: { text: "Calibration: predicted P_S (binned) against the observed success rate", x: 0.02, font: { size: 13 } },
      font: FONT,
      margin: { l: 50, r: 12, t: 36, b: 44 },
      xaxis: { title: { text: "predicted P_S" }, range: [0, 1] },
      yaxis: { title: { text: "observed success rate" }, range: [0, 1.02] },
      shapes: [{ type: "line", x0: 0, y0: 0, x1: 1, y1: 1, line: { color: "#9ca3af", dash: "dot", width: 1 } }],
      paper_bgcolor: "rgba(0,0,0,0)",
      plot_bgcolor: "rgba(0,0,0,0)",
    },
    CONFIG,
  );
  box.dataset.streams = String(traces.length);
}
