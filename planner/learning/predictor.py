"""The trained models as the search's :class:`~planner.search.learned.Predictor`."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from planner.learning.model import CostModel
from planner.search.learned import StreamCost

if TYPE_CHECKING:
    from planner.domains.spec import LoadedDomain


class ModelPredictor:
    """Groups rows by stream so each stream's rows go through its network in one pass."""

    def __init__(self, model: CostModel) -> None:
        self.model = model

    @classmethod
    def load(cls, path: Path, *, domain: LoadedDomain) -> ModelPredictor:
        return cls(CostModel.load(path, domain=domain))

    def trusted(self) -> frozenset[str] | None:
        """The streams whose network predicted ``P_S`` better than the stream's prior on the
        runs held out in training (validation log loss below the prior's), as the model file
        records (LearnedConfig.trust); None when it records no validation (trust them all)."""
        return self.model.trusted_streams()

    def predict_rows(
        self, rows: Sequence[tuple[str, Sequence[Any | None], Mapping[str, Any]]]
    ) -> list[StreamCost]:
        by_stream: dict[str, list[int]] = defaultdict(list)
        for i, (stream, _, _) in enumerate(rows):
            by_stream[stream].append(i)
        out: list[StreamCost | None] = [None] * len(rows)
        for stream, indices in by_stream.items():
            pred = self.model.predict_queries(stream, [(rows[i][1], rows[i][2]) for i in indices])
            columns = (pred.p_s.tolist(), pred.r_s.tolist(), pred.r_f.tolist(), pred.r_m.tolist())
            for i, p_s, r_s, r_f, r_m in zip(indices, *columns, strict=True):
                out[i] = StreamCost(p_s, r_s, r_f, r_m)
        return [c for c in out if c is not None]
