"""Learned models for any domain: the generic state encoding (fluent facts and the values they
hold) on the tutorial domain's recorded queries, a model trained, saved and loaded on them, and
the learned planner on per-stream priors when a domain has no model."""

from __future__ import annotations

import logging
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest

from planner.api import RunConfig
from planner.domains import LoadedDomain, load_domain
from planner.learning.features import FactFeatures, FeatureError, Featurizer
from planner.learning.model import CostModel
from planner.learning.priors import priors_from_records, priors_from_store
from planner.learning.train import LoadedRecords, load_records, train
from planner.runs import record_run
from planner.store import RunStore

TUTORIAL = Path(__file__).resolve().parents[2] / "examples" / "tabletop2d"


@pytest.fixture(scope="module")
def tabletop() -> LoadedDomain:
    return load_domain(TUTORIAL)


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory, tabletop: LoadedDomain) -> LoadedRecords:
    """The stream queries of six recorded baseline runs of tabletop-3 (pure Python, fast)."""
    db = tmp_path_factory.mktemp("records") / "runs.db"
    with RunStore(db) as store:
        for seed in range(6):
            config = RunConfig(
                scene="tabletop-3", seed=seed, budget_s=30, domain=str(tabletop.directory)
            )
            run_id = store.create_run(config.scene, seed, config.planner, asdict(config))
            assert record_run(config, store, run_id).status == "solved"
    loaded = load_records([db])
    assert loaded.domains() == {"tabletop2d": 6}
    return loaded


def test_the_state_part_counts_facts_and_carries_their_values(
    records: LoadedRecords, tabletop: LoadedDomain
) -> None:
    featurizer = Featurizer.fit(records, domain=tabletop)
    names = featurizer.feature_names("test-cfree")
    assert len(names) == featurizer.width("test-cfree")
    tests = [r for r in records if r.stream == "test-cfree"]
    crowded = max(
        tests, key=lambda r: sum(f[0] == "in" and f[2] == "goal" for f in r.context["facts"])
    )
    row = featurizer.row("test-cfree", crowded.inputs, crowded.context)
    in_goal = sum(f[0] == "in" and f[2] == "goal" for f in crowded.context["facts"])
    assert in_goal >= 1
    assert row[names.index("n[in]")] == sum(f[0] == "in" for f in crowded.context["facts"])
    for fact in crowded.context["facts"]:
        if fact[0] == "in" and f"({' '.join(fact)})" in names:
            assert row[names.index(f"({' '.join(fact)})")] == 1.0
    # An "at" fact of a placed block carries that block's pose: its two numbers.
    placed = next(
        f for f in crowded.context["facts"] if f[0] == "at" and f[2] in crowded.context["values"]
    )
    key = "at " + placed[1] + (" *" if placed[2].startswith("opt-") else f" {placed[2]}")
    start = names.index(f"({key}).arg2.unbound")
    assert row[start] == 0.0
    assert row[start + 1 : start + 3].tolist() == pytest.approx(
        crowded.context["values"][placed[2]]["xy"]
    )
    # The same facts with the pose not bound yet: the mask bit, no numbers.
    unbound = {**crowded.context, "values": {}}
    row = featurizer.row("test-cfree", crowded.inputs, unbound)
    assert row[start] == 1.0 and not row[start + 1 : start + 3].any()
    with pytest.raises(FeatureError, match="malformed fact"):
        featurizer.row("test-cfree", crowded.inputs, {"facts": [["at", 3]], "values": {}})


def test_rows_that_share_a_context_are_the_rows_of_each_query_alone(
    records: LoadedRecords, tabletop: LoadedDomain
) -> None:
    """A search's rows queried in one state share their context object, whose state part the
    featurizer computes once: each row is still the one its own query gives."""
    featurizer = Featurizer.fit(records, domain=tabletop)
    tests = [r for r in records if r.stream == "test-cfree"][:40]
    contexts = {repr(r.context): r.context for r in tests}
    assert len(contexts) >= 2  # queries in different states
    # Every query's inputs against every context object, twice over, interleaved.
    queries = [(r.inputs, c) for c in contexts.values() for r in tests[:5]] * 2
    together = featurizer.matrix("test-cfree", queries)
    for row, (inputs, context) in zip(together, queries, strict=True):
        alone = Featurizer.fit(records, domain=tabletop).row(
            "test-cfree", inputs, {**context, "facts": list(context["facts"])}
        )
        assert row.tolist() == alone.tolist()
    assert len({tuple(r) for r in together}) > len(tests[:5])  # the contexts differ in rows


def test_a_model_trains_saves_and_loads_for_the_tutorial(
    records: LoadedRecords, tabletop: LoadedDomain, tmp_path: Path
) -> None:
    model, report = train(records, domain=tabletop, seed=0, epochs=60, min_queries=20)
    assert model.featurizer.spec.state["kind"] == FactFeatures.kind
    assert {s.stream for s in report.streams} >= {"test-cfree", "inverse-kinematics"}
    path = tmp_path / "tabletop.pt"
    model.save(path)
    again = CostModel.load(path, domain=tabletop)
    for stream in model.streams:
        rows = model.featurizer.matrix(
            stream, [(r.inputs, r.context) for r in records if r.stream == stream]
        )
        assert np.array_equal(
            rows,
            again.featurizer.matrix(
                stream, [(r.inputs, r.context) for r in records if r.stream == stream]
            ),
        )
        assert np.array_equal(model.predict(stream, rows).p_s, again.predict(stream, rows).p_s)
    with pytest.raises(Exception, match="trained for domain 'tabletop2d', this is 'kitchen'"):
        CostModel.load(path, domain=load_domain("kitchen"))


def test_an_input_of_a_class_with_no_value_type_is_refused_by_name(
    records: LoadedRecords, tabletop: LoadedDomain
) -> None:
    opaque = {"type": "opaque", "python_type": "mine.Shape", "repr": "Shape()"}
    odd = next(r for r in records if r.stream == "sample-pose")
    bad = type(odd)(**{**asdict(odd), "inputs": [odd.inputs[0], opaque]})
    with pytest.raises(
        FeatureError, match=r"mine\.Shape have no value type in domain 'tabletop2d'"
    ):
        Featurizer.fit([bad], domain=tabletop)


def test_learned_without_a_model_runs_on_the_stores_priors(
    records: LoadedRecords, tabletop: LoadedDomain, caplog: pytest.LogCaptureFixture
) -> None:
    from planner.api import solve

    db = records.sources[0]
    config = RunConfig(
        scene="tabletop-3",
        seed=50,
        planner="learned",
        budget_s=30,
        domain=str(tabletop.directory),
        priors_db=str(db),
    )
    with caplog.at_level(logging.WARNING, logger="planner.planners"):
        out = solve(config)
    assert out.status == "solved"
    warned = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warned) == 1
    assert f"priors from {len(records)} queries recorded in {db}" in warned[0]
    # summed in the store, the priors are those of the queries one by one
    summed, n = priors_from_store(Path(db), "tabletop2d")
    one_by_one = priors_from_records(records)
    assert n == len(records) and summed.keys() == one_by_one.keys()
    for stream, prior in summed.items():
        expected = one_by_one[stream]
        assert (prior.p_s, prior.n) == (expected.p_s, expected.n)
        assert [prior.r_s, prior.r_f, prior.r_m] == pytest.approx(
            [expected.r_s, expected.r_f, expected.r_m]
        )
