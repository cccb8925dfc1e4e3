"""What a stream does on average (:class:`Prior`), and a predictor made of priors alone.

The learned planner needs a model of each stream. When a domain has no trained model yet,
:class:`PriorPredictor` answers every row of a stream with that stream's success rate and mean
costs over recorded queries (:func:`priors_from_records`), or with uniform figures
(:data:`UNIFORM`) when nothing is recorded: the search then runs Eq. 4 on averages, which is
what the paper's models predict before they have seen anything. No torch here.
"""

from __future__ import annotations

import logging
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import numpy.typing as npt

from planner.search.learned import StreamCost

if TYPE_CHECKING:
    from planner.store import OutcomeSums
from planner.streams.adapters import RESTATING, restates_contract

log = logging.getLogger(__name__)

Float64Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Prediction:
    """Predictions for a batch of rows of one stream; costs in seconds."""

    p_s: Float64Array  # success probability
    r_s: Float64Array  # seconds of a successful query
    r_f: Float64Array  # seconds of a failed query
    r_m: Float64Array  # seconds to execute the produced trajectory (0 if none)

    def __post_init__(self) -> None:
        shapes = {a.shape for a in (self.p_s, self.r_s, self.r_f, self.r_m)}
        if len(shapes) != 1 or len(next(iter(shapes))) != 1:
            raise ValueError(f"p_s, r_s, r_f, r_m must be 1-D of one length, got {shapes}")

    def __len__(self) -> int:
        return len(self.p_s)


@dataclass(frozen=True)
class Prior:
    """What a stream does on average: used where there is no network (or no data for a head)."""

    p_s: float  # success rate, Laplace-smoothed: (successes + 1) / (queries + 2)
    r_s: float  # mean seconds of a successful query
    r_f: float  # mean seconds of a failed query
    r_m: float  # mean execution seconds of a success's trajectory (0 if none)
    n: int  # queries it was computed from

    def __post_init__(self) -> None:
        if not 0.0 < self.p_s < 1.0:
            raise ValueError(f"prior p_s must be in (0, 1), got {self.p_s}")
        if min(self.r_s, self.r_f, self.r_m) < 0 or self.n < 0:
            raise ValueError(f"prior costs and n must be >= 0, got {self}")

    @classmethod
    def from_outcomes(
        cls, success: npt.ArrayLike, wall_s: npt.ArrayLike, execution_s: npt.ArrayLike
    ) -> Prior:
        """Success rate and mean costs of some queries; a missing outcome borrows the other's
        mean seconds (a stream that never failed: a failure is assumed to cost what a success
        does)."""
        ok = np.asarray(success, dtype=bool)
        wall = np.asarray(wall_s, dtype=np.float64)
        execution = np.asarray(execution_s, dtype=np.float64)
        n = len(ok)
        overall = float(wall.mean()) if n else 0.0
        r_s = float(wall[ok].mean()) if ok.any() else overall
        r_f = float(wall[~ok].mean()) if (~ok).any() else overall
        moved = execution[ok & (execution > 0)]
        r_m = float(moved.mean()) if len(moved) else 0.0
        return cls((int(ok.sum()) + 1) / (n + 2), r_s, r_f, r_m, n)

    def to_dict(self) -> dict[str, Any]:
        return {"p_s": self.p_s, "r_s": self.r_s, "r_f": self.r_f, "r_m": self.r_m, "n": self.n}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Prior:
        return cls(
            float(data["p_s"]),
            float(data["r_s"]),
            float(data["r_f"]),
            float(data["r_m"]),
            int(data["n"]),
        )

    def predict(self, n: int) -> Prediction:
        return Prediction(
            np.full(n, self.p_s), np.full(n, self.r_s), np.full(n, self.r_f), np.full(n, self.r_m)
        )


# Every stream alike when nothing is recorded: even odds, a second per query, no motion.
UNIFORM = Prior(p_s=0.5, r_s=1.0, r_f=1.0, r_m=0.0, n=0)


class OutcomeLike(Protocol):
    """What priors read of a recorded query (:class:`planner.store.QueryRecord` is one)."""

    @property
    def stream(self) -> str: ...

    @property
    def success(self) -> bool: ...

    @property
    def wall_s(self) -> float: ...

    @property
    def execution_s(self) -> float: ...


def priors_from_records(records: Iterable[OutcomeLike]) -> dict[str, Prior]:
    """Each stream's prior over the given queries, leaving out the answers that only restate
    an adapter's contract (no sampler ran: :func:`planner.streams.adapters.restates_contract`)."""
    by_stream: dict[str, list[OutcomeLike]] = defaultdict(list)
    for r in records:
        if not r.success and restates_contract(getattr(r, "reason", None)):
            continue
        by_stream[r.stream].append(r)
    return {
        stream: Prior.from_outcomes(
            [r.success for r in rs], [r.wall_s for r in rs], [r.execution_s for r in rs]
        )
        for stream, rs in sorted(by_stream.items())
    }


def priors_from_store(path: Path, domain: str) -> tuple[dict[str, Prior], int]:
    """Each stream's prior over the queries of the runs of ``domain`` (its name) recorded in
    the store at ``path``, and how many queries that was. Reads only how each query ended (not
    its inputs or context) and each run's scene once: a learned run on priors pays little for
    it inside its planning clock, however large the store."""
    from planner.domains import domain_of_scene, find_scene, load_domain
    from planner.scene import SceneError
    from planner.store import RunStore

    with RunStore(path) as store:
        runs = store.query_runs()
        domains: dict[tuple[str, str | None], str | None] = {}
        for scene, ref in set(runs.values()):
            try:
                given = load_domain(ref) if ref is not None else None
                domains[(scene, ref)] = domain_of_scene(find_scene(scene, domain=given), given).name
            except (OSError, ValueError, KeyError, SceneError) as exc:
                log.warning("scene %s: cannot load it to tell its domain (%s)", scene, exc)
                domains[(scene, ref)] = None
        mine = sorted(run for run, key in runs.items() if domains[key] == domain)
        sums = store.outcome_sums(mine, leave_out=RESTATING)
    return priors_from_sums(sums), sum(s.n for s in sums)


def priors_from_sums(sums: Iterable[OutcomeSums]) -> dict[str, Prior]:
    """Each stream's prior from its queries summed by outcome (what
    :func:`priors_from_records` computes one query at a time)."""
    by_stream: dict[str, dict[bool, OutcomeSums]] = defaultdict(dict)
    for s in sums:
        by_stream[s.stream][s.success] = s
    out = {}
    for stream, parts in sorted(by_stream.items()):
        ok, failed = parts.get(True), parts.get(False)
        n_ok = ok.n if ok else 0
        n = n_ok + (failed.n if failed else 0)
        overall = ((ok.wall_s if ok else 0.0) + (failed.wall_s if failed else 0.0)) / max(n, 1)
        r_s = ok.wall_s / ok.n if ok and ok.n else overall
        r_f = failed.wall_s / failed.n if failed and failed.n else overall
        r_m = ok.execution_s / ok.moved if ok and ok.moved else 0.0
        out[stream] = Prior((n_ok + 1) / (n + 2), r_s, r_f, r_m, n)
    return out


class PriorPredictor:
    """A :class:`~planner.search.learned.Predictor` that knows only per-stream averages."""

    def __init__(self, priors: Mapping[str, Prior], default: Prior = UNIFORM) -> None:
        self.priors = dict(priors)
        self.default = default

    def prior(self, stream: str) -> Prior:
        return self.priors.get(stream, self.default)

    def trusted(self) -> frozenset[str]:
        """None: an average tells no query of a stream from another (LearnedConfig.trust)."""
        return frozenset()

    def predict_rows(
        self, rows: Sequence[tuple[str, Sequence[Any | None], Mapping[str, Any]]]
    ) -> list[StreamCost]:
        out = []
        for stream, _, _ in rows:
            p = self.prior(stream)
            out.append(StreamCost(p.p_s, p.r_s, p.r_f, p.r_m))
        return out
