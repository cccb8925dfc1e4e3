"""Per-stream cost models: an MLP per stream predicting P_S, R_S, R_F and R_M, and the model file.

Each network maps a feature row (:mod:`planner.learning.features`) to four outputs: the logit of
P_S (success probability) and the log-seconds of R_S (a successful query), R_F (a failed query)
and R_M (executing the trajectory a success produces). Costs come back as ``exp`` of the
predicted log-seconds, so they are never negative. A stream without a network, or a cost head
without training targets (R_F of a stream that never failed, R_M of a stream that moves
nothing), answers with the stream's PRIOR: its training success rate and mean costs.

The model file is a ``torch.save`` dict of tensors and plain data (state dicts, the feature spec,
priors, metadata), read back with ``torch.load(..., weights_only=True)``: loading never unpickles
code.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import torch
from torch import nn

from planner.learning.features import FEATURE_VERSION, FeatureError, Featurizer
from planner.learning.priors import Prediction, Prior

if TYPE_CHECKING:
    from planner.domains.spec import LoadedDomain

MODEL_FORMAT = "guided-tamp/cost-model"  # the "format" field of a model file
MODEL_FORMAT_VERSION = 1  # layout of the file's dict (not of the features: FEATURE_VERSION)
HIDDEN = 64  # units in each of the two hidden layers
MIN_SECONDS = 1e-6  # costs are floored here before taking logs (a grasp sample takes ~50 us)
MAX_SECONDS = 1e6  # predicted costs are capped here (exp of a wild extrapolation)
COST_HEADS = ("r_s", "r_f", "r_m")
# Predictions run on one torch thread: a search's batches are tens to hundreds of rows through
# 64-unit layers, too small to gain from intra-op threads, and on a machine whose cores are all
# busy (a benchmark's workers, the dashboard) those threads wait on each other (docs/BENCHMARKS.md,
# *Seconds per node as the tree grows*).
INFERENCE_THREADS = 1

Float64Array = npt.NDArray[np.float64]


class ModelError(Exception):
    """A model file is missing, is not a model file, or does not fit this code or domain."""


def _gist(exc: Exception) -> str:
    """The telling line of a load error (torch's weights-only refusal is a page of advice)."""
    lines = [re.sub(r"\x1b\[[0-9;]*m", "", ln).strip() for ln in str(exc).splitlines()]
    lines = [ln for ln in lines if ln]
    telling = [ln for ln in lines if "Unsupported global" in ln or "WeightsUnpickler" in ln]
    return (telling or lines or [""])[0]


@contextmanager
def torch_threads(n: int) -> Iterator[None]:
    """Run the block with ``n`` intra-op torch threads (deterministic, polite on shared boxes)."""
    before = torch.get_num_threads()
    torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(before)


class StreamNet(nn.Module):
    """in -> 64 -> 64 -> 4 (ReLU). Inputs are standardised and cost outputs de-standardised by
    buffers fitted on the training data, so they travel inside the state dict."""

    x_mean: torch.Tensor
    x_std: torch.Tensor
    y_mean: torch.Tensor
    y_std: torch.Tensor

    def __init__(self, n_in: int, hidden: int = HIDDEN) -> None:
        super().__init__()
        if n_in < 1 or hidden < 1:
            raise ValueError(f"n_in and hidden must be >= 1, got {n_in}, {hidden}")
        self.n_in = n_in
        self.hidden = hidden
        self.register_buffer("x_mean", torch.zeros(n_in))
        self.register_buffer("x_std", torch.ones(n_in))
        self.register_buffer("y_mean", torch.zeros(len(COST_HEADS)))  # log-seconds
        self.register_buffer("y_std", torch.ones(len(COST_HEADS)))
        self.body = nn.Sequential(
            nn.Linear(n_in, hidden),
            nn.ReLU(),
            nn.Linear(hidden, hidden),
            nn.ReLU(),
            nn.Linear(hidden, 1 + len(COST_HEADS)),
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Raw outputs: the P_S logit and the standardised log-seconds of R_S, R_F, R_M."""
        out: torch.Tensor = self.body((x - self.x_mean) / self.x_std)
        return out


@dataclass(frozen=True, eq=False)
class StreamNetwork:
    """A trained network and which cost heads had targets; the others answer with the prior."""

    net: StreamNet
    heads: tuple[bool, bool, bool]  # trained: R_S (successes), R_F (failures), R_M (motion)


class CostModel:
    """Per-stream predictions of P_S, R_S, R_F, R_M from feature rows.

    ``streams`` are those with a network or a prior; any other stream gets ``default_prior``
    (the success rate and mean costs of all training queries).
    """

    def __init__(
        self,
        featurizer: Featurizer,
        networks: Mapping[str, StreamNetwork],
        priors: Mapping[str, Prior],
        *,
        default_prior: Prior,
        metadata: Mapping[str, Any] | None = None,
    ) -> None:
        for stream, network in networks.items():
            if stream not in priors:
                raise ValueError(f"stream {stream!r} has a network but no prior")
            if network.net.n_in != featurizer.width(stream):
                raise ValueError(
                    f"stream {stream!r}: network takes {network.net.n_in} features, the "
                    f"featurizer makes {featurizer.width(stream)}"
                )
        try:  # plain types only: the file must load with weights_only=True
            meta: dict[str, Any] = json.loads(json.dumps(dict(metadata or {}), allow_nan=False))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"model metadata must be plain JSON data: {exc}") from exc
        self.featurizer = featurizer
        self.networks = dict(networks)
        self.priors = dict(priors)
        self.default_prior = default_prior
        self.metadata = meta
        for network in self.networks.values():
            network.net.eval()

    def __repr__(self) -> str:
        return (
            f"CostModel(domain={self.domain!r}, networks={sorted(self.networks)}, "
            f"priors only={sorted(set(self.priors) - set(self.networks))})"
        )

    @property
    def domain(self) -> str:
        return self.featurizer.spec.domain

    @property
    def streams(self) -> tuple[str, ...]:
        return tuple(sorted(set(self.networks) | set(self.priors)))

    def trusted_streams(self) -> frozenset[str] | None:
        """The streams whose network beat the prior on validation (log loss of ``P_S`` lower
        than the prior's on the held-out runs); None when the file has no validation figures
        (a model saved before they were kept: every stream trusted)."""
        validation = self.metadata.get("validation")
        if not isinstance(validation, dict) or not isinstance(validation.get("streams"), list):
            return None
        out = set()
        for report in validation["streams"]:
            if not isinstance(report, dict) or report.get("prior_used"):
                continue
            loss, prior = report.get("log_loss"), report.get("prior_log_loss")
            if isinstance(loss, int | float) and isinstance(prior, int | float) and loss < prior:
                out.add(str(report.get("stream")))
        return frozenset(out)

    def prior(self, stream: str) -> Prior:
        return self.priors.get(stream, self.default_prior)

    def predict(self, stream: str, rows: npt.ArrayLike) -> Prediction:
        """Predictions for rows of ``stream`` (shape ``(n, featurizer.width(stream))``), in one
        forward pass."""
        x = np.asarray(rows, dtype=np.float32)
        if x.ndim != 2:
            raise ValueError(f"rows must be 2-D (n, features), got shape {x.shape}")
        network = self.networks.get(stream)
        prior = self.prior(stream)
        if network is None:
            return prior.predict(len(x))
        if x.shape[1] != network.net.n_in:
            raise ValueError(
                f"stream {stream!r} takes rows of {network.net.n_in} features, got {x.shape[1]}"
            )
        if len(x) == 0:
            return prior.predict(0)
        with torch.inference_mode(), torch_threads(INFERENCE_THREADS):
            out = network.net(torch.from_numpy(x)).double()
            log_costs = network.net.y_mean.double() + network.net.y_std.double() * out[:, 1:]
            p_s = torch.sigmoid(out[:, 0]).numpy()
            costs = torch.exp(log_costs.clamp(math.log(MIN_SECONDS), math.log(MAX_SECONDS)))
        cost_arrays = costs.numpy()
        columns = []
        for j, (head, trained) in enumerate(zip(COST_HEADS, network.heads, strict=True)):
            if trained:
                columns.append(np.ascontiguousarray(cost_arrays[:, j]))
            else:
                columns.append(np.full(len(x), float(getattr(prior, head))))
        return Prediction(np.ascontiguousarray(p_s), columns[0], columns[1], columns[2])

    def predict_queries(
        self, stream: str, queries: Sequence[tuple[Sequence[Any | None], Mapping[str, Any]]]
    ) -> Prediction:
        """Featurize ``(inputs, context)`` queries of one stream and predict them."""
        return self.predict(stream, self.featurizer.matrix(stream, queries))

    # --- the model file ----------------------------------------------------------------------

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the model file (atomically: a reader never sees half a file)."""
        target = Path(path)
        target.parent.mkdir(parents=True, exist_ok=True)
        payload: dict[str, Any] = {
            "format": MODEL_FORMAT,
            "format_version": MODEL_FORMAT_VERSION,
            "domain": self.domain,
            "feature_spec": self.featurizer.spec.to_dict(),
            "networks": {
                stream: {
                    "n_in": network.net.n_in,
                    "hidden": network.net.hidden,
                    "heads": list(network.heads),
                    "state_dict": dict(network.net.state_dict()),
                }
                for stream, network in sorted(self.networks.items())
            },
            "priors": {s: p.to_dict() for s, p in sorted(self.priors.items())},
            "default_prior": self.default_prior.to_dict(),
            "metadata": self.metadata,
        }
        tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
        try:
            torch.save(payload, tmp)
            tmp.replace(target)
        finally:
            tmp.unlink(missing_ok=True)

    @classmethod
    def load(cls, path: str | os.PathLike[str], *, domain: LoadedDomain) -> CostModel:
        """Read a model file written by :meth:`save` for ``domain`` (its value types and feature
        hook rebuild the featurizer); :class:`ModelError` names what is wrong (missing file, not a
        model file, other domain, other feature version)."""
        source = Path(path)
        if not source.is_file():
            raise ModelError(f"no model file at {source}")
        try:
            data = torch.load(source, map_location="cpu", weights_only=True)
        except Exception as exc:
            raise ModelError(
                f"{source} is not a cost-model file ({type(exc).__name__}: {_gist(exc)})"
            ) from exc
        if not isinstance(data, dict) or data.get("format") != MODEL_FORMAT:
            found = data.get("format") if isinstance(data, dict) else type(data).__name__
            raise ModelError(
                f"{source} is not a cost-model file (format {found!r}, expected {MODEL_FORMAT!r})"
            )
        if data.get("format_version") != MODEL_FORMAT_VERSION:
            raise ModelError(
                f"{source}: model file format version {data.get('format_version')!r}, this code "
                f"reads version {MODEL_FORMAT_VERSION}"
            )
        if data.get("domain") != domain.name:
            raise ModelError(
                f"{source}: model trained for domain {data.get('domain')!r}, this is "
                f"{domain.name!r}"
            )
        try:
            spec = data["feature_spec"]
            if spec.get("version") != FEATURE_VERSION:
                raise ModelError(
                    f"{source}: model uses feature version {spec.get('version')!r}, this code "
                    f"computes version {FEATURE_VERSION}: retrain the model"
                )
            featurizer = Featurizer.from_spec(spec, domain=domain)
            networks = {}
            for stream, entry in data["networks"].items():
                net = StreamNet(int(entry["n_in"]), int(entry["hidden"]))
                net.load_state_dict(entry["state_dict"])
                heads = tuple(bool(h) for h in entry["heads"])
                if len(heads) != len(COST_HEADS):
                    raise ValueError(f"stream {stream!r}: expected 3 head flags, got {heads}")
                networks[stream] = StreamNetwork(net, (heads[0], heads[1], heads[2]))
            priors = {s: Prior.from_dict(p) for s, p in data["priors"].items()}
            return cls(
                featurizer,
                networks,
                priors,
                default_prior=Prior.from_dict(data["default_prior"]),
                metadata=data.get("metadata") or {},
            )
        except ModelError:
            raise
        except (FeatureError, KeyError, TypeError, ValueError, AttributeError, RuntimeError) as exc:
            raise ModelError(f"{source}: malformed cost-model file: {exc}") from exc
