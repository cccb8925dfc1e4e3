"""Training per-stream cost models on recorded stream queries, and the validation report.

Queries are split into training and validation BY RUN (queries of one run are correlated: same
scene, same search), seeded. For each stream with at least ``min_queries`` queries an MLP is fit
full-batch with Adam on: binary cross-entropy for success; squared error of log-seconds for R_S
on successes (wall seconds), R_F on failures (wall seconds) and R_M on successes that produced a
trajectory (execution seconds). A stream with too few queries keeps its prior (success rate and
mean costs) and a warning is logged.

The data are small and the scene features are constant within a run, so an unregularised
network memorises runs (training loss ~0, validation worse than the prior). Each Adam step
therefore sees freshly corrupted rows: value inputs (poses, grasps, confs) unbound at random,
which is also what the planner asks about before those inputs are sampled; the scene part
zeroed for half the rows; Gaussian noise on every feature."""

from __future__ import annotations

import dataclasses
import json
import logging
import math
from collections import Counter
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import torch
from torch import nn

from planner.domains import LoadedDomain, problem_for_scene
from planner.learning.features import FEATURE_VERSION, Featurizer
from planner.learning.model import (
    COST_HEADS,
    MIN_SECONDS,
    CostModel,
    StreamNet,
    StreamNetwork,
    torch_threads,
)
from planner.learning.priors import Prediction, Prior
from planner.scene import SceneError
from planner.store import QueryRecord, RunStore
from planner.streams.adapters import restates_contract

log = logging.getLogger(__name__)

EPOCHS = 300  # full-batch Adam steps per stream
LEARNING_RATE = 3e-3  # Adam step size
WEIGHT_DECAY = 1e-4  # Adam L2 penalty
UNBIND_PROBABILITY = 0.25  # per epoch: chance that a value input of a row is unbound
SCENE_DROP_PROBABILITY = 0.5  # per epoch: chance that a row's scene features are zeroed
INPUT_NOISE = 0.3  # per epoch: std of Gaussian noise on every feature (metres, radians, 0/1)
TORCH_THREADS = 1  # deterministic results, and polite to planners sharing the machine


class LoadedRecords(list[QueryRecord]):
    """Stream queries read by :func:`load_records`, remembering where they came from (the model
    file's metadata names the data) and the domain of each run."""

    def __init__(
        self,
        records: Iterable[QueryRecord],
        *,
        sources: Sequence[Path | str] = (),
        run_scenes: Mapping[str, str] | None = None,
        run_seeds: Mapping[str, int] | None = None,
        run_domains: Mapping[str, str] | None = None,
        domains_found: Mapping[str, LoadedDomain] | None = None,
    ) -> None:
        super().__init__(records)
        self.sources = tuple(sources)
        self.run_scenes = dict(run_scenes or {})
        self.run_seeds = dict(run_seeds or {})
        self.run_domains = dict(run_domains or {})  # run id -> domain name ("?": unknown)
        self.domains_found = dict(domains_found or {})  # domain name -> the loaded domain

    def training_seeds(self) -> dict[str, list[int]]:
        """Scene -> the seeds of its runs (benchmarks must hold these out)."""
        out: dict[str, set[int]] = {}
        for run_id, scene in self.run_scenes.items():
            if run_id in self.run_seeds:
                out.setdefault(scene, set()).add(self.run_seeds[run_id])
        return {scene: sorted(seeds) for scene, seeds in sorted(out.items())}

    def domains(self) -> dict[str, int]:
        """Domain name -> how many of the records' runs are of it."""
        runs = {r.run_id for r in self}
        counts: dict[str, int] = {}
        for run_id in runs:
            name = self.run_domains.get(run_id, "?")
            counts[name] = counts.get(name, 0) + 1
        return dict(sorted(counts.items()))


@dataclass
class _SceneInfo:
    domain: LoadedDomain | None  # None: the scene no longer loads
    static: dict[str, Any]


def _scene_info(scene: str, domain_ref: str | None, cache: dict[Any, _SceneInfo]) -> _SceneInfo:
    """The domain and static context of a recorded run's scene (a scene that no longer loads
    has neither, and says so once in the log)."""
    key = (scene, domain_ref)
    if key not in cache:
        try:
            loaded, problem = problem_for_scene(scene, seed=0, domain=domain_ref)
            cache[key] = _SceneInfo(loaded, loaded.static_context(problem))
        except (OSError, ValueError, KeyError, SceneError) as exc:
            log.warning("scene %s: cannot load it to tell its domain (%s)", scene, exc)
            cache[key] = _SceneInfo(None, {})
    return cache[key]


def _with_static_context(query: QueryRecord, static: Mapping[str, Any]) -> QueryRecord:
    """The query with its scene's static context where it was recorded without one: stores
    written before queries carried it train the same model."""
    missing = {k: v for k, v in static.items() if k not in query.context}
    if not missing:
        return query
    return dataclasses.replace(query, context={**missing, **query.context})


def load_records(
    db_paths: Sequence[Path | str],
    *,
    domain: str | None = None,
    run_ids: Collection[str] | None = None,
) -> LoadedRecords:
    """Every stream query in the given run stores (SQLite files, or database URLs), in stored
    order; with ``domain`` (a domain's name), only the queries of that domain's runs; with
    ``run_ids``, only those of these runs."""
    records: list[QueryRecord] = []
    scenes: dict[str, str] = {}
    seeds: dict[str, int] = {}
    domains: dict[str, str] = {}
    loaded_domains: dict[str, LoadedDomain] = {}
    seen: set[tuple[str, int]] = set()
    cache: dict[Any, _SceneInfo] = {}
    wanted = None if run_ids is None else sorted(set(run_ids))
    for raw in db_paths:
        url = isinstance(raw, str) and "://" in raw
        path: Path | str = raw if url else Path(raw)
        if isinstance(path, Path) and not path.is_file():
            raise FileNotFoundError(f"no run store at {path}")
        with RunStore(path) as store:
            queries = store.stream_queries(run_ids=wanted)
            info: dict[str, _SceneInfo] = {}
            for run_id in sorted({q.run_id for q in queries}):
                run = store.get_run(run_id)
                scenes[run_id], seeds[run_id] = run.scene, run.seed
                ref = run.config.get("domain")
                info[run_id] = _scene_info(run.scene, ref if isinstance(ref, str) else None, cache)
                found = info[run_id].domain
                domains[run_id] = "?" if found is None else found.name
                if found is not None:
                    loaded_domains[found.name] = found
        kept = 0
        for q in queries:
            if (q.run_id, q.seq) in seen:
                continue  # the same store given twice
            seen.add((q.run_id, q.seq))
            if domain is not None and domains[q.run_id] != domain:
                continue
            records.append(_with_static_context(q, info[q.run_id].static))
            kept += 1
        log.info("%s: %d stream queries (%d kept)", path, len(queries), kept)
    return LoadedRecords(
        records,
        sources=[p if isinstance(p, str) and "://" in p else Path(p) for p in db_paths],
        run_scenes=scenes,
        run_seeds=seeds,
        run_domains=domains,
        domains_found=loaded_domains,
    )


def records_domain(records: LoadedRecords) -> LoadedDomain:
    """The one domain of the records' runs; ValueError says which domains they hold when there
    are several, or runs whose scene no longer loads."""
    domains = records.domains()
    if len(domains) != 1 or "?" in domains:
        found = ", ".join(f"{d} ({n} runs)" for d, n in domains.items()) or "no runs"
        raise ValueError(
            f"the runs are of {found}: choose one domain"
            + (" ('?': runs whose scene no longer loads)" if "?" in domains else "")
        )
    return records.domains_found[next(iter(domains))]


# --- the report ------------------------------------------------------------------------------


CALIBRATION_BINS = 10  # equal-width bins of predicted P_S in the calibration of a stream


@dataclass(frozen=True)
class CalibrationBin:
    """Validation queries whose predicted ``P_S`` fell in ``[low, high)``: how many, their mean
    prediction and the fraction that succeeded (a calibrated model has the two equal)."""

    low: float
    high: float
    n: int
    predicted: float
    observed: float


def calibration(
    labels: npt.ArrayLike, p_s: npt.ArrayLike, bins: int = CALIBRATION_BINS
) -> tuple[CalibrationBin, ...]:
    """Equal-width bins of the predictions, the empty ones left out (1.0 falls in the last)."""
    y = np.asarray(labels, dtype=bool)
    p = np.asarray(p_s, dtype=np.float64)
    index = np.minimum((p * bins).astype(int), bins - 1)
    out = []
    for b in range(bins):
        where = index == b
        n = int(where.sum())
        if n:
            out.append(
                CalibrationBin(
                    b / bins, (b + 1) / bins, n, float(p[where].mean()), float(y[where].mean())
                )
            )
    return tuple(out)


@dataclass(frozen=True)
class StreamReport:
    """Validation of one stream's model against its prior (errors in seconds; None: no data)."""

    stream: str
    n_train: int
    n_val: int
    prior_used: bool  # too few queries: the model answers with the prior
    success_rate: float | None  # in the training queries (None: no training queries)
    auc: float | None  # of P_S on validation; None when validation holds one class only
    log_loss: float | None  # of P_S on validation
    prior_log_loss: float | None
    mae_r_s: float | None  # median |error| of R_S on validation successes
    mae_r_f: float | None  # ... of R_F on validation failures
    mae_r_m: float | None  # ... of R_M on validation successes that move
    prior_mae_r_s: float | None
    prior_mae_r_f: float | None
    prior_mae_r_m: float | None
    # Predicted P_S on validation, binned: how often the queries of each bin succeeded.
    calibration: tuple[CalibrationBin, ...] = ()


@dataclass(frozen=True)
class TrainReport:
    streams: tuple[StreamReport, ...]
    train_runs: tuple[str, ...]
    val_runs: tuple[str, ...]
    seed: int
    epochs: int
    # Per stream: the recorded queries used as rows (training and validation), and those left
    # out, by why (an answer that only restates its adapter's contract: no sampler ran).
    rows: Mapping[str, int] = dataclasses.field(default_factory=dict)
    left_out: Mapping[str, Mapping[str, int]] = dataclasses.field(default_factory=dict)

    def stream(self, name: str) -> StreamReport:
        for s in self.streams:
            if s.stream == name:
                return s
        known = ", ".join(s.stream for s in self.streams)
        raise KeyError(f"no stream {name!r} in the report (streams: {known})")

    def to_dict(self) -> dict[str, Any]:
        return {
            "seed": self.seed,
            "epochs": self.epochs,
            "train_runs": list(self.train_runs),
            "val_runs": list(self.val_runs),
            "streams": [asdict(s) for s in self.streams],
            "rows": dict(self.rows),
            "left_out": {k: dict(v) for k, v in self.left_out.items()},
        }


def _num(value: float | None, digits: int = 3) -> str:
    return "-" if value is None else f"{value:.{digits}g}"


def _percent(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.1f}"


def format_report(report: TrainReport) -> str:
    """A table: per stream, sizes, AUC and log loss of P_S, and median absolute errors of the
    costs on validation, each with the prior's value in parentheses."""
    header = (
        f"{'stream':<20} {'train':>6} {'val':>5} {'model':>6} {'ok%':>5} {'AUC':>5} "
        f"{'logloss (prior)':>16} {'|err| R_S s (prior)':>20} {'|err| R_F s (prior)':>20} "
        f"{'|err| R_M s (prior)':>20}"
    )
    lines = [
        f"{len(report.train_runs)} training runs, {len(report.val_runs)} validation runs, "
        f"seed {report.seed}, {report.epochs} epochs",
        header,
        "-" * len(header),
    ]

    def pair(model: float | None, prior: float | None) -> str:
        return f"{_num(model)} ({_num(prior)})"

    for s in report.streams:
        lines.append(
            f"{s.stream:<20} {s.n_train:>6} {s.n_val:>5} {'prior' if s.prior_used else 'mlp':>6} "
            f"{_percent(s.success_rate):>5} {_num(s.auc, 2):>5} "
            f"{pair(s.log_loss, s.prior_log_loss):>16} {pair(s.mae_r_s, s.prior_mae_r_s):>20} "
            f"{pair(s.mae_r_f, s.prior_mae_r_f):>20} {pair(s.mae_r_m, s.prior_mae_r_m):>20}"
        )
    lines.append("rows (recorded queries) per stream:")
    for stream in sorted({*report.rows, *report.left_out}):
        left = report.left_out.get(stream, {})
        line = f"  {stream}: {report.rows.get(stream, 0)} used"
        if left:
            why = "; ".join(f"{n} {reason!r}" for reason, n in sorted(left.items()))
            line += (
                f", {sum(left.values())} left out: answers that only restate the adapter's "
                f"contract, no sampler ran ({why})"
            )
        lines.append(line)
    return "\n".join(lines)


# --- metrics ---------------------------------------------------------------------------------


def auc(labels: npt.ArrayLike, scores: npt.ArrayLike) -> float | None:
    """Area under the ROC curve (Mann-Whitney U with tied scores sharing their mean rank);
    None when only one class occurs."""
    y = np.asarray(labels, dtype=bool)
    s = np.asarray(scores, dtype=np.float64)
    n_pos = int(y.sum())
    n_neg = len(y) - n_pos
    if n_pos == 0 or n_neg == 0:
        return None
    order = np.argsort(s, kind="mergesort")
    sorted_scores = s[order]
    ranks = np.empty(len(s), dtype=np.float64)
    start = 0
    while start < len(s):
        end = start
        while end + 1 < len(s) and sorted_scores[end + 1] == sorted_scores[start]:
            end += 1
        ranks[order[start : end + 1]] = (start + end) / 2 + 1  # 1-based mean rank of the tie
        start = end + 1
    u = ranks[y].sum() - n_pos * (n_pos + 1) / 2
    return float(u / (n_pos * n_neg))


def _log_loss(labels: npt.NDArray[np.bool_], p: npt.NDArray[np.float64]) -> float | None:
    if len(labels) == 0:
        return None
    q = np.clip(p, 1e-7, 1 - 1e-7)
    return float(-np.mean(np.where(labels, np.log(q), np.log(1 - q))))


def _median_abs(
    predicted: npt.NDArray[np.float64], actual: npt.NDArray[np.float64], where: npt.NDArray[Any]
) -> float | None:
    if not where.any():
        return None
    return float(np.median(np.abs(predicted[where] - actual[where])))


# --- training --------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Targets:
    success: npt.NDArray[np.bool_]
    wall_s: npt.NDArray[np.float64]
    execution_s: npt.NDArray[np.float64]

    @classmethod
    def of(cls, records: Sequence[QueryRecord]) -> _Targets:
        return cls(
            np.array([r.success for r in records], dtype=bool),
            np.array([r.wall_s for r in records], dtype=np.float64),
            np.array([r.execution_s for r in records], dtype=np.float64),
        )

    def head_masks(self, moves: bool) -> npt.NDArray[np.bool_]:
        """(n, 3): which rows carry a target for R_S, R_F, R_M."""
        ok = self.success
        return np.stack([ok, ~ok, ok & (self.execution_s > 0) & moves], axis=1)

    def log_costs(self) -> npt.NDArray[np.float64]:
        """(n, 3) log-seconds targets of R_S, R_F (both wall) and R_M (execution)."""
        wall = np.log(np.maximum(self.wall_s, MIN_SECONDS))
        execution = np.log(np.maximum(self.execution_s, MIN_SECONDS))
        return np.stack([wall, wall, execution], axis=1)


def sampler_outcomes(
    records: Sequence[QueryRecord],
) -> tuple[list[QueryRecord], dict[str, Counter[str]]]:
    """The queries that are the samplers' outcomes, and per stream how many were left out and
    why: a failure whose reason only restates its adapter's contract (a PDDLStream function's
    one output already given, a list used up, a test or an ended generator asked again,
    :func:`planner.streams.adapters.restates_contract`) is no outcome of the sampler, which did
    not run; no feature can predict it, and half the rows of a PDDLStream stream were such."""
    kept: list[QueryRecord] = []
    left: dict[str, Counter[str]] = {}
    for r in records:
        if not r.success and restates_contract(r.reason):
            left.setdefault(r.stream, Counter())[str(r.reason)] += 1
        else:
            kept.append(r)
    return kept, left


def split_runs(
    run_ids: Iterable[str], *, val_fraction: float, seed: int
) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Seeded split of run ids into (train, validation); validation gets ``val_fraction`` of
    the runs (at least one when there are two or more runs and the fraction is positive)."""
    if not 0.0 <= val_fraction < 1.0:
        raise ValueError(f"val_fraction must be in [0, 1), got {val_fraction}")
    runs = sorted(set(run_ids))
    n_val = round(val_fraction * len(runs))
    if val_fraction > 0 and len(runs) >= 2:
        n_val = min(max(n_val, 1), len(runs) - 1)
    order = np.random.default_rng(seed).permutation(len(runs))
    val = tuple(sorted(runs[i] for i in order[:n_val]))
    train = tuple(sorted(runs[i] for i in order[n_val:]))
    return train, val


@dataclass(frozen=True)
class _Corruption:
    """Per-epoch corruption of training rows (fresh each epoch, seeded).

    Value inputs (every kind but names: poses, grasps, numbers, ...) are unbound (zeroed, mask
    bit set) as the planner asks about streams before their inputs are sampled; the state part
    is dropped now and then, as
    it is constant within a run and a network keys on it to memorise runs; small Gaussian noise
    on every feature smooths the fit. Names (problem objects) are always bound.
    """

    value_slots: tuple[tuple[int, int], ...]  # (offset, width) of each value slot
    scene: tuple[int, int]  # (offset, width) of the state part

    @classmethod
    def of(cls, featurizer: Featurizer, stream: str) -> _Corruption:
        slots = []
        offset = 0  # the stream part after the slots is never corrupted but by noise
        for kind, width in featurizer.slots(stream):
            if kind != "name":
                slots.append((offset, width))
            offset += width
        return cls(tuple(slots), (featurizer.scene_offset(stream), featurizer.scene_width))

    def apply(self, x: torch.Tensor, generator: torch.Generator) -> torch.Tensor:
        out = x.clone()
        n = len(x)
        for offset, width in self.value_slots:
            drop = torch.rand(n, generator=generator) < UNBIND_PROBABILITY
            out[drop, offset : offset + width] = 0.0
            out[drop, offset] = 1.0
        start, width = self.scene
        drop = torch.rand(n, generator=generator) < SCENE_DROP_PROBABILITY
        out[drop, start : start + width] = 0.0
        return out + INPUT_NOISE * torch.randn(out.shape, generator=generator)


def _loss(
    out: torch.Tensor, success: torch.Tensor, z: torch.Tensor, mask: torch.Tensor
) -> torch.Tensor:
    """Binary cross-entropy of success plus the mean squared error of each cost head over the
    rows that carry its target."""
    counts = mask.sum(0).clamp(min=1.0)
    bce = nn.functional.binary_cross_entropy_with_logits(out[:, 0], success)
    return bce + (((out[:, 1:] - z) ** 2 * mask).sum(0) / counts).sum()


@dataclass(frozen=True)
class _Batch:
    """Rows and targets as tensors (z: log-seconds standardised by the network's buffers)."""

    x: torch.Tensor
    success: torch.Tensor
    z: torch.Tensor
    mask: torch.Tensor

    @classmethod
    def of(cls, x: npt.NDArray[np.float32], t: _Targets, moves: bool, net: StreamNet) -> _Batch:
        y = (t.log_costs() - net.y_mean.numpy()) / net.y_std.numpy()
        return cls(
            torch.from_numpy(x),
            torch.from_numpy(t.success.astype(np.float32)),
            torch.from_numpy(y.astype(np.float32)),
            torch.from_numpy(t.head_masks(moves).astype(np.float32)),
        )


def _new_network(
    x: npt.NDArray[np.float32], t: _Targets, moves: bool, prior: Prior, seed: int
) -> StreamNet:
    """A seeded network whose buffers centre the inputs (scaling only spreads above 1, so rare
    one-hot columns are not blown up) and standardise the log-seconds targets, with the success
    logit starting at the prior's."""
    heads = t.head_masks(moves)
    y_log = t.log_costs()
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        net = StreamNet(x.shape[1])
    x_t = torch.from_numpy(x)
    net.x_mean.copy_(x_t.mean(0))
    net.x_std.copy_(x_t.std(0).clamp(min=1.0) if len(x) > 1 else torch.ones(x.shape[1]))
    for j in range(len(COST_HEADS)):
        col = y_log[heads[:, j], j]
        if len(col):
            net.y_mean[j] = float(col.mean())
            net.y_std[j] = float(col.std()) if len(col) > 1 and col.std() > 0.05 else 1.0
    last = net.body[-1]
    assert isinstance(last, nn.Linear)
    with torch.no_grad():
        last.bias.zero_()
        last.bias[0] = math.log(prior.p_s / (1 - prior.p_s))
    return net


@dataclass(frozen=True)
class TrainProgress:
    """How far training is: stream ``index`` (from 0) of ``streams`` is at ``epoch`` of
    ``epochs`` (0 when it starts; a stream left to its prior jumps to the end)."""

    stream: str
    index: int
    streams: int
    epoch: int
    epochs: int

    @property
    def fraction(self) -> float:
        return (self.index + self.epoch / max(self.epochs, 1)) / max(self.streams, 1)


ProgressCallback = Callable[[TrainProgress], None]
PROGRESS_EVERY = 10  # epochs between two progress reports


def _epochs_of(
    say: ProgressCallback, stream: str, index: int, streams: int, epochs: int
) -> Callable[[int], None]:
    """What tells ``say`` the epochs of one stream."""
    return lambda epoch: say(TrainProgress(stream, index, streams, epoch, epochs))


def _run_adam(
    net: StreamNet,
    batch: _Batch,
    corruption: _Corruption,
    *,
    epochs: int,
    seed: int,
    on_epoch: Callable[[int], None] | None = None,
) -> None:
    """Full-batch Adam, each step on freshly corrupted rows; ``on_epoch(n)`` every
    :data:`PROGRESS_EVERY` epochs."""
    generator = torch.Generator().manual_seed(seed)
    optimiser = torch.optim.Adam(net.parameters(), lr=LEARNING_RATE, weight_decay=WEIGHT_DECAY)
    net.train()
    for epoch in range(epochs):
        optimiser.zero_grad()
        out = net(corruption.apply(batch.x, generator))
        loss = _loss(out, batch.success, batch.z, batch.mask)
        loss.backward()  # type: ignore[no-untyped-call]
        optimiser.step()
        if on_epoch is not None and (epoch + 1) % PROGRESS_EVERY == 0:
            on_epoch(epoch + 1)
    net.eval()


def _fit_stream(
    records: Sequence[QueryRecord],
    featurizer: Featurizer,
    stream: str,
    prior: Prior,
    *,
    seed: int,
    epochs: int,
    on_epoch: Callable[[int], None] | None = None,
) -> StreamNetwork:
    t = _Targets.of(records)
    moves = bool((t.execution_s > 0).any())
    x = featurizer.matrix(stream, ((r.inputs, r.context) for r in records))
    net = _new_network(x, t, moves, prior, seed)
    corruption = _Corruption.of(featurizer, stream)
    batch = _Batch.of(x, t, moves, net)
    _run_adam(net, batch, corruption, epochs=epochs, seed=seed, on_epoch=on_epoch)
    heads = [bool(t.head_masks(moves)[:, j].any()) for j in range(len(COST_HEADS))]
    return StreamNetwork(net, (heads[0], heads[1], heads[2]))


def _evaluate(
    stream: str,
    model: CostModel,
    records: Sequence[QueryRecord],
    moves: bool,
    *,
    n_train: int,
    prior_used: bool,
    success_rate: float | None,
) -> StreamReport:
    x = model.featurizer.matrix(stream, ((r.inputs, r.context) for r in records))
    t = _Targets.of(records)
    heads = t.head_masks(moves)
    predicted = model.predict(stream, x)
    baseline = model.prior(stream).predict(len(records))

    def errors(p: Prediction) -> list[float | None]:
        return [
            _median_abs(p.r_s, t.wall_s, heads[:, 0]),
            _median_abs(p.r_f, t.wall_s, heads[:, 1]),
            _median_abs(p.r_m, t.execution_s, heads[:, 2]),
        ]

    mae = errors(predicted)
    prior_mae = errors(baseline)
    return StreamReport(
        stream=stream,
        n_train=n_train,
        n_val=len(records),
        prior_used=prior_used,
        success_rate=success_rate,
        auc=auc(t.success, predicted.p_s),
        log_loss=_log_loss(t.success, predicted.p_s),
        prior_log_loss=_log_loss(t.success, baseline.p_s),
        mae_r_s=mae[0],
        mae_r_f=mae[1],
        mae_r_m=mae[2],
        prior_mae_r_s=prior_mae[0],
        prior_mae_r_f=prior_mae[1],
        prior_mae_r_m=prior_mae[2],
        calibration=calibration(t.success, predicted.p_s),
    )


def train(
    records: Sequence[QueryRecord],
    *,
    domain: LoadedDomain,
    seed: int = 0,
    epochs: int = EPOCHS,
    val_fraction: float = 0.2,
    min_queries: int = 30,
    metadata: Mapping[str, Any] | None = None,
    progress: ProgressCallback | None = None,
) -> tuple[CostModel, TrainReport]:
    """Fit one network per stream on the training runs and report on the validation runs.

    ``domain`` gives the value types and the state features of the rows. ``metadata`` is
    stored in the model file, on top of what is known: the number of runs and queries, seed,
    date, the validation report and, for :func:`load_records` output, the data files and
    scene names. ``progress`` hears how far training is (:class:`TrainProgress`).
    """
    if not records:
        raise ValueError("no stream queries to train on")
    if epochs < 1:
        raise ValueError(f"epochs must be >= 1, got {epochs}")
    if min_queries < 1:
        raise ValueError(f"min_queries must be >= 1, got {min_queries}")
    given = records
    records, left_out = sampler_outcomes(records)
    if not records:
        raise ValueError(
            "no stream queries to train on: every recorded query only restates its adapter's "
            "contract (no sampler ran)"
        )
    train_runs, val_runs = split_runs(
        (r.run_id for r in records), val_fraction=val_fraction, seed=seed
    )
    val_set = set(val_runs)
    training = [r for r in records if r.run_id not in val_set]
    validation = [r for r in records if r.run_id in val_set]
    featurizer = Featurizer.fit(training, domain=domain)
    streams = sorted({r.stream for r in records})
    networks: dict[str, StreamNetwork] = {}
    priors: dict[str, Prior] = {}
    fallback: set[str] = set()
    say = progress or (lambda _p: None)
    with torch_threads(TORCH_THREADS):
        for index, stream in enumerate(streams):
            say(TrainProgress(stream, index, len(streams), 0, epochs))
            ours = [r for r in training if r.stream == stream]
            total = sum(1 for r in records if r.stream == stream)
            t = _Targets.of(ours or [r for r in records if r.stream == stream])
            priors[stream] = Prior.from_outcomes(t.success, t.wall_s, t.execution_s)
            if total < min_queries or not ours:
                log.warning(
                    "stream %s: %d queries (%d for training), fewer than min_queries=%d: "
                    "its model is the prior (success rate %.2f, mean costs)",
                    stream,
                    total,
                    len(ours),
                    min_queries,
                    priors[stream].p_s,
                )
                fallback.add(stream)
                continue
            networks[stream] = _fit_stream(
                ours,
                featurizer,
                stream,
                priors[stream],
                seed=seed * 1000 + index,
                epochs=epochs,
                on_epoch=_epochs_of(say, stream, index, len(streams), epochs),
            )
            log.info("stream %s: trained on %d queries", stream, len(ours))
    all_t = _Targets.of(training)
    default_prior = Prior.from_outcomes(all_t.success, all_t.wall_s, all_t.execution_s)
    meta: dict[str, Any] = {
        "runs": len(train_runs) + len(val_runs),
        "train_runs": len(train_runs),
        "val_runs": len(val_runs),
        "queries": len(records),
        "queries_per_stream": {s: sum(1 for r in records if r.stream == s) for s in streams},
        "seed": seed,
        "epochs": epochs,
        "feature_version": FEATURE_VERSION,
        "trained_at": datetime.now(UTC).isoformat(timespec="seconds"),
        "torch": str(torch.__version__),
        "training": {
            "val_fraction": val_fraction,
            "min_queries": min_queries,
            "learning_rate": LEARNING_RATE,
            "weight_decay": WEIGHT_DECAY,
            "unbind_probability": UNBIND_PROBABILITY,
            "scene_drop_probability": SCENE_DROP_PROBABILITY,
            "input_noise": INPUT_NOISE,
        },
    }
    meta["left_out"] = {k: dict(v) for k, v in left_out.items()}
    if isinstance(given, LoadedRecords):
        meta["data"] = [str(p) for p in given.sources]
        meta["scenes"] = sorted(set(given.run_scenes.values()))
        meta["training_seeds"] = given.training_seeds()
    meta.update(metadata or {})
    model = CostModel(featurizer, networks, priors, default_prior=default_prior, metadata=meta)
    reports = []
    for stream in streams:
        ours_train = [r for r in training if r.stream == stream]
        ours_val = [r for r in validation if r.stream == stream]
        succ = float(np.mean([r.success for r in ours_train])) if ours_train else None
        moves = any(r.execution_s > 0 for r in ours_train)
        reports.append(
            _evaluate(
                stream,
                model,
                ours_val,
                moves,
                n_train=len(ours_train),
                prior_used=stream in fallback,
                success_rate=succ,
            )
        )
    rows = {stream: sum(1 for r in records if r.stream == stream) for stream in streams}
    report = TrainReport(
        tuple(reports),
        train_runs,
        val_runs,
        seed,
        epochs,
        rows,
        {k: dict(v) for k, v in left_out.items()},
    )
    # The file carries its validation figures (as plain JSON data, what a loaded file holds).
    model.metadata["validation"] = json.loads(json.dumps(report.to_dict(), allow_nan=False))
    return model, report
