"""Features, per-stream cost models and training, on synthetic kitchen-like stream queries with
rules a model can learn (no recorded database, no simulation)."""

from __future__ import annotations

import dataclasses
import json
import logging
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch

from planner.domains import load_domain
from planner.learning.features import FEATURE_VERSION, FeatureError, Featurizer
from planner.learning.model import CostModel, ModelError
from planner.learning.priors import priors_from_records
from planner.learning.train import TrainReport, auc, format_report, split_runs, train
from planner.store import QueryRecord
from planner.streams.adapters import ONCE

KITCHEN = load_domain("kitchen")  # these are the kitchen's own features (its feature hook)
PLATFORMS = ("table", "sink", "stove")
ARM = [0.0, 1.17, -3.34, -2.25, 0.0, -1.7, 0.0]


def _pose(x: float, y: float, yaw: float) -> dict[str, Any]:
    return {"type": "pose", "x": x, "y": y, "z": 0.755, "yaw": yaw}


def _grasp(kind: str) -> dict[str, Any]:
    return {
        "type": "grasp",
        "kind": kind,
        "position": [0.0, 0.0, 0.01],
        "quat_xyzw": [0.0, 0.7071, 0.0, 0.7071] if kind == "top" else [0.0, 0.0, 0.0, 1.0],
        "approach": 0.08,
    }


def _conf(x: float, y: float, yaw: float) -> dict[str, Any]:
    return {"type": "conf", "base": [x, y, yaw], "torso": 0.2, "arm": ARM, "approach_arm": None}


class _Runs:
    """Synthetic runs. Rules: a placement on the stove succeeds iff fewer than 2 blocks are on
    the stove; IK takes longer the farther the block is from the origin; a motion's execution
    seconds grow with the base distance; sample-grasp is queried only in a few runs."""

    def __init__(self, n_runs: int, seed: int, *, grasp_runs: int = 5) -> None:
        self.rng = np.random.default_rng(seed)
        self.records: list[QueryRecord] = []
        for r in range(n_runs):
            self._run(f"run{r:03d}", with_grasps=r < grasp_runs)

    def _add(
        self, run_id: str, stream: str, inputs: list[Any], ok: bool, wall: float, **kw: Any
    ) -> None:
        n = len(self.records)
        self.records.append(
            QueryRecord(
                id=n + 1,
                run_id=run_id,
                node_id=n,
                seq=n,
                stream=stream,
                input_names=[f"x{i}" for i in range(len(inputs))],
                inputs=inputs,
                success=ok,
                wall_s=wall,
                cpu_s=wall,
                execution_s=kw.get("execution_s", 0.0),
                error=None,
                context=kw["context"],
            )
        )

    def _run(self, run_id: str, *, with_grasps: bool) -> None:
        rng = self.rng
        n_blocks = int(rng.integers(2, 6))
        blocks = [f"b{i}" for i in range(1, n_blocks + 1)]
        where = {b: str(rng.choice(PLATFORMS)) for b in blocks}
        poses = {}
        for b in blocks:
            x, y = rng.uniform(-1.5, 1.5, 2)
            poses[b] = _pose(float(x), float(y), float(rng.uniform(-math.pi, math.pi)))
        facts = [["at-conf", "q0"], ["can-move"], ["hand-empty"]]
        facts += [["at-pose", b, f"p0-{b}"] for b in blocks] + [["on", b, where[b]] for b in blocks]
        context = {
            "facts": sorted(facts),
            "values": {f"p0-{b}": poses[b] for b in blocks} | {"q0": _conf(0, 0, 0)},
        }
        on_stove = sum(1 for b in blocks if where[b] == "stove")
        for _ in range(6):
            b, target = str(rng.choice(blocks)), str(rng.choice(PLATFORMS))
            ok = target != "stove" or on_stove < 2
            wall = 1e-4 * rng.uniform(0.8, 1.2)
            self._add(run_id, "sample-placement", [b, target], ok, wall, context=context)
        for _ in range(8):
            b = str(rng.choice(blocks))
            dist = math.hypot(poses[b]["x"], poses[b]["y"])
            ok = bool(rng.random() < 0.6)
            wall = (0.02 + 0.2 * dist) * rng.uniform(0.95, 1.05) * (1.0 if ok else 0.5)
            inputs = [b, poses[b], _grasp(str(rng.choice(["top", "side"])))]
            self._add(run_id, "inverse-kinematics", inputs, ok, wall, context=context)
        for _ in range(4):
            q1, q2 = rng.uniform(-2, 2, 3).tolist(), rng.uniform(-2, 2, 3).tolist()
            moved = 2.0 + 3.0 * math.hypot(q2[0] - q1[0], q2[1] - q1[1])
            inputs = [_conf(q1[0], q1[1], q1[2]), _conf(q2[0], q2[1], q2[2])]
            wall = 0.5 * rng.uniform(0.9, 1.1)
            self._add(run_id, "plan-motion", inputs, True, wall, execution_s=moved, context=context)
        if with_grasps:
            self._add(run_id, "sample-grasp", [blocks[0]], True, 5e-5, context=context)


@pytest.fixture(scope="module")
def data() -> list[QueryRecord]:
    return _Runs(40, seed=1).records


@pytest.fixture(scope="module")
def trained(data: list[QueryRecord]) -> tuple[CostModel, TrainReport]:
    return train(data, domain=KITCHEN, seed=0, epochs=300)


# --- features --------------------------------------------------------------------------------


def test_rows_have_a_fixed_length_per_stream_and_mask_unbound_inputs(
    data: list[QueryRecord],
) -> None:
    featurizer = Featurizer.fit(data, domain=KITCHEN)
    ik = next(r for r in data if r.stream == "inverse-kinematics")
    names = featurizer.feature_names("inverse-kinematics")
    width = featurizer.width("inverse-kinematics")
    assert len(names) == width

    bound = featurizer.row("inverse-kinematics", ik.inputs, ik.context)
    unbound = featurizer.row("inverse-kinematics", [ik.inputs[0], ik.inputs[1], None], ik.context)
    assert bound.shape == unbound.shape == (width,)
    assert bound.dtype == np.float32

    grasp = [i for i, n in enumerate(names) if n.startswith("in2.")]
    mask = names.index("in2.unbound")
    assert bound[mask] == 0.0 and unbound[mask] == 1.0
    assert not unbound[[i for i in grasp if i != mask]].any()  # an unbound input is zeros
    assert bound[names.index("in1.unbound")] == unbound[names.index("in1.unbound")] == 0.0
    # the pose slot: x, y, z, cos yaw, sin yaw
    pose = ik.inputs[1]
    start = names.index("in1.unbound") + 1
    assert bound[start : start + 5] == pytest.approx(
        [pose["x"], pose["y"], 0.755, math.cos(pose["yaw"]), math.sin(pose["yaw"])], abs=1e-6
    )
    # a name outside the vocabulary falls in the unknown bucket (a block's name is cleared
    # altogether: test_relative_features_do_not_stop_at_eight_blocks)
    odd = featurizer.row("inverse-kinematics", ["crate7", None, None], ik.context)
    assert odd[names.index("in0.is_unknown")] == 1.0
    block = featurizer.row("inverse-kinematics", ["b99", None, None], ik.context)
    assert not block[[i for i, n in enumerate(names) if n.startswith("in0.is_")]].any()

    arity = {"sample-grasp": 1, "sample-placement": 2, "plan-motion": 2}
    for stream, n in arity.items():
        row = featurizer.row(stream, [None] * n, {})
        assert row.shape == (featurizer.width(stream),)
        # nothing bound, no scene: only the mask bits are set (and a placement's room unknown)
        assert row.sum() == n + (stream == "sample-placement")


def test_a_placement_sees_the_room_left_on_its_platform() -> None:
    """The room features read the platform's footprint and the block's size from the context's
    geometry: three blocks in three corners of a 22 cm stove leave the fourth corner free (its
    centre 15 cm from theirs); one in the middle of an edge leaves no spot more than ~8 cm from
    a block, too close for a 7 cm block that may be turned."""
    featurizer = Featurizer.fit([], domain=KITCHEN)
    names = featurizer.feature_names("sample-placement")
    geometry = {"platforms": {"stove": [-0.11, 0.11, -1.26, -1.04]}, "blocks": {"b4": 0.07}}

    def room(*xy: tuple[float, float]) -> tuple[float, float, float]:
        blocks = [f"b{i}" for i in range(1, len(xy) + 1)]
        context = {
            "geometry": geometry,
            "facts": [["on", b, "stove"] for b in blocks]
            + [["at-pose", b, f"p{b}"] for b in blocks],
            "values": {f"p{b}": _pose(x, y, 0.0) for b, (x, y) in zip(blocks, xy, strict=True)},
        }
        row = featurizer.row("sample-placement", ["b4", "stove"], context)
        return tuple(float(row[names.index(f"room.{k}")]) for k in ("unknown", "cm", "blocks"))

    corners = [(-0.075, -1.225), (0.075, -1.225), (-0.075, -1.075)]
    unknown, free, n = room(*corners)
    assert (unknown, n) == (0.0, 3.0) and free == pytest.approx(15.0)
    _, crowded, _ = room((0.0, -1.225), (-0.075, -1.075), (0.075, -1.075))
    assert crowded < 10.0  # on the 9 x 9 grid of centres: 9.4 cm
    assert room()[1] == pytest.approx(30.0)  # an empty stove: plenty
    # One context, two blocks: each row is the room its own block has (a search's rows of one
    # state share their context, and the featurizer keeps parts by what they read).
    shared = {
        "geometry": {**geometry, "blocks": {"b4": 0.07, "b5": 0.30}},
        "facts": [["on", "b1", "stove"], ["at-pose", "b1", "pb1"]],
        "values": {"pb1": _pose(-0.075, -1.225, 0.0)},
    }
    rows = [featurizer.row("sample-placement", [b, "stove"], shared) for b in ("b4", "b5", "b4")]
    alone = [
        Featurizer.fit([], domain=KITCHEN).row("sample-placement", [b, "stove"], dict(shared))
        for b in ("b4", "b5")
    ]
    cm = names.index("room.cm")
    assert rows[0][cm] > 10.0 and rows[1][cm] == 0.0  # b5 is wider than the stove
    assert [r.tolist() for r in rows] == [a.tolist() for a in (*alone, alone[0])]
    # Without geometry (a store recorded before it was in the context): unknown.
    row = featurizer.row("sample-placement", ["b4", "stove"], {"facts": [], "values": {}})
    assert row[names.index("room.unknown")] == 1.0
    # Malformed geometry names what is wrong instead of crashing somewhere deeper.
    for bad in ({"platforms": [], "blocks": {}}, {**geometry, "blocks": {"b4": "wide"}}):
        with pytest.raises(FeatureError, match="geometry"):
            featurizer.row("sample-placement", ["b4", "stove"], {"geometry": bad, "facts": []})


def _layout(featurizer: Featurizer, layout: str) -> Featurizer:
    """The same features with the kitchen's state in ``layout`` (the shipped model's "names")."""
    spec = featurizer.spec.to_dict()
    return Featurizer.from_spec(
        {**spec, "state": {**spec["state"], "layout": layout}}, domain=KITCHEN
    )


def test_scene_features_read_the_facts() -> None:
    featurizer = _layout(Featurizer.fit([], domain=KITCHEN), "names")  # the shipped model's
    context = {
        "facts": [
            ["at-pose", "b1", "p1"],
            ["on", "b1", "stove"],
            ["on", "b2", "stove"],
            ["on", "b3", "sink"],
            ["on", "b11", "stove"],  # past the padded blocks (kitchen-12): counted all the same
            ["holding", "b4", "g"],
        ],
        "values": {"p1": _pose(0.5, -0.25, 0.0)},
    }
    row = featurizer.row("sample-grasp", ["b1"], context)
    names = featurizer.feature_names("sample-grasp")

    def f(name: str) -> float:
        return float(row[names.index(name)])

    assert [f("b1.present"), f("b1.on_stove"), f("b1.x"), f("b1.y"), f("b1.cos_yaw")] == [
        1.0,
        1.0,
        0.5,
        -0.25,
        1.0,
    ]
    assert f("b2.x") == 0.0  # pose not known: zeros
    assert [f("b4.present"), f("b4.held"), f("b4.on_table")] == [1.0, 1.0, 0.0]
    assert [f("b5.present"), f("b8.present")] == [0.0, 0.0]  # padded to max_blocks
    assert (f("n_on_stove"), f("n_on_sink")) == (3.0, 1.0)


def test_relative_features_do_not_stop_at_eight_blocks() -> None:
    """What tamp train fits: a row is as wide for kitchen-24 as for kitchen-4, and a query about
    b17 of a long kitchen reads b17's own state; renamed, it reads exactly what a query about b2
    in the same state of a short kitchen reads (names say nothing of a block)."""
    featurizer = Featurizer.fit([], domain=KITCHEN)
    assert featurizer.spec.state["layout"] == "relative"
    names = featurizer.feature_names("inverse-kinematics")

    def state(blocks: list[str], me: str) -> dict[str, Any]:
        facts = [["on", b, "stove"] for b in blocks if b != me]
        facts += [["cooked", b] for b in blocks if b != me]
        facts += [["on", me, "sink"], ["at-pose", me, "pm"], ["cleaned", me], ["hand-empty"]]
        return {"facts": facts, "values": {"pm": _pose(0.02, 1.1, 0.3)}}

    long = [f"b{i}" for i in range(1, 25)]
    short = ["b1", "b2", "b3", "b4"]
    inputs = ["b17", {"type": "pose", "x": 0.0, "y": 1.1, "z": 0.755, "yaw": 0.0}, None]
    row = featurizer.row("inverse-kinematics", inputs, state(long, "b17"))
    assert row.shape == (featurizer.width("inverse-kinematics"),)

    def f(r: Any, name: str) -> float:
        return float(r[names.index(name)])

    own = [f(row, f"own.{k}") for k in ("present", "on_sink", "on_stove", "held", "x", "y")]
    assert own == pytest.approx([1.0, 1.0, 0.0, 0.0, 0.02, 1.1])
    assert [f(row, n) for n in ("n_stove", "n_sink", "n_cooked", "n_cleaned")] == [23, 1, 23, 1]
    # The same state in a kitchen of four blocks, the query about b2: only the counts differ.
    small = featurizer.row("inverse-kinematics", ["b2", *inputs[1:]], state(short, "b2"))
    differ = [n for n, a, b in zip(names, row, small, strict=True) if a != b]
    assert differ == ["n_stove", "n_cooked"]
    # A motion is about the block the hand holds.
    held = {"facts": [["holding", "b21", "g"], ["on", "b3", "table"]], "values": {}}
    motion = featurizer.feature_names("plan-motion")
    m = featurizer.row("plan-motion", [None, None], held)
    assert m[motion.index("own.present")] == 1.0 and m[motion.index("own.held")] == 1.0


def test_feature_spec_round_trips_through_a_plain_dict(data: list[QueryRecord]) -> None:
    featurizer = Featurizer.fit(data, domain=KITCHEN)
    spec = json.loads(json.dumps(featurizer.spec.to_dict()))
    again = Featurizer.from_spec(spec, domain=KITCHEN)
    assert again.spec == featurizer.spec
    assert spec["version"] == FEATURE_VERSION and spec["state"]["max_blocks"] == 8
    for r in data[:50]:
        assert np.array_equal(
            again.row(r.stream, r.inputs, r.context), featurizer.row(r.stream, r.inputs, r.context)
        )


# --- training --------------------------------------------------------------------------------


def test_auc_is_rank_based_with_ties() -> None:
    assert auc([0, 0, 1, 1], [0.1, 0.4, 0.35, 0.8]) == pytest.approx(0.75)
    assert auc([0, 1, 0, 1], [0.5, 0.5, 0.5, 0.5]) == pytest.approx(0.5)
    assert auc([1, 1, 1], [0.2, 0.3, 0.4]) is None


def test_learns_the_synthetic_rules_and_beats_the_prior(
    trained: tuple[CostModel, TrainReport],
) -> None:
    _model, report = trained
    placement = report.stream("sample-placement")
    assert not placement.prior_used
    assert placement.auc is not None and placement.auc > 0.9
    assert placement.log_loss is not None and placement.prior_log_loss is not None
    assert placement.log_loss < 0.5 * placement.prior_log_loss

    ik = report.stream("inverse-kinematics")  # success is a coin flip: nothing to learn
    assert ik.auc is not None and 0.3 < ik.auc < 0.7
    assert ik.mae_r_s is not None and ik.prior_mae_r_s is not None
    assert ik.mae_r_s < 0.8 * ik.prior_mae_r_s  # wall time grows with distance
    assert ik.mae_r_f is not None and ik.prior_mae_r_f is not None
    assert ik.mae_r_f < 0.8 * ik.prior_mae_r_f

    motion = report.stream("plan-motion")
    assert motion.mae_r_m is not None and motion.prior_mae_r_m is not None
    assert motion.mae_r_m < 0.5 * motion.prior_mae_r_m
    assert "sample-placement" in format_report(report)
    json.dumps(report.to_dict())


def test_answers_that_restate_the_contract_are_left_out_and_counted(
    data: list[QueryRecord],
) -> None:
    """A PDDLStream function asked again answers "already given" without running its
    sampler: no feature can predict that, so such rows are no training rows; the report (and
    the model file) says per stream how many rows were used and how many left out, and why."""
    ik = [r for r in data if r.stream == "inverse-kinematics"]
    restated = [
        dataclasses.replace(r, id=10_000 + i, success=False, reason=ONCE)
        for i, r in enumerate(ik[::2])
    ]
    model, report = train([*data, *restated], domain=KITCHEN, seed=0, epochs=5)
    assert report.rows["inverse-kinematics"] == len(ik)
    assert report.left_out == {"inverse-kinematics": {ONCE: len(restated)}}
    counts = report.stream("inverse-kinematics")
    assert counts.n_train + counts.n_val == len(ik)  # the restated rows are in neither
    text = format_report(report)
    assert f"inverse-kinematics: {len(ik)} used, {len(restated)} left out" in text
    assert "only restate the adapter's contract" in text
    assert model.metadata["left_out"] == {"inverse-kinematics": {ONCE: len(restated)}}
    with pytest.raises(ValueError, match="only restates its adapter's contract"):
        train(restated, domain=KITCHEN, seed=0, epochs=5)
    priors = priors_from_records([*data, *restated])
    alone = priors_from_records(data)
    assert priors["inverse-kinematics"] == alone["inverse-kinematics"]


def test_a_stream_is_trusted_where_its_validation_beat_its_prior(
    trained: tuple[CostModel, TrainReport],
) -> None:
    """LearnedConfig.trust reads the model file's validation: a stream's predictions are
    trusted where its network's held-out log loss beat the stream's average."""
    model, report = trained
    trusted = model.trusted_streams()
    assert trusted is not None and "sample-placement" in trusted
    for s in report.streams:
        beat = (
            not s.prior_used
            and s.log_loss is not None
            and s.prior_log_loss is not None
            and s.log_loss < s.prior_log_loss
        )
        assert (s.stream in trusted) == beat, s
    unvalidated = CostModel(
        model.featurizer, model.networks, model.priors, default_prior=model.default_prior
    )
    assert unvalidated.trusted_streams() is None  # a file without figures: trusted throughout


def test_predictions_are_batched_and_non_negative(
    trained: tuple[CostModel, TrainReport], data: list[QueryRecord]
) -> None:
    model, _ = trained
    ik = [r for r in data if r.stream == "inverse-kinematics"][:20]
    rows = model.featurizer.matrix("inverse-kinematics", [(r.inputs, r.context) for r in ik])
    pred = model.predict("inverse-kinematics", rows)
    assert len(pred) == 20
    assert ((pred.p_s > 0) & (pred.p_s < 1)).all()
    assert (pred.r_s > 0).all() and (pred.r_f > 0).all()
    assert (pred.r_m == 0).all()  # IK produces no trajectory
    # unbound pose and grasp (the planner scoring a stream before its inputs exist)
    unbound = model.predict_queries("inverse-kinematics", [(["b1", None, None], ik[0].context)])
    assert np.isfinite([unbound.p_s, unbound.r_s, unbound.r_f]).all()
    # nearer blocks are predicted to be cheaper for IK
    ctx = ik[0].context
    near = model.predict_queries("inverse-kinematics", [(["b1", _pose(0.2, 0, 0), None], ctx)])
    far = model.predict_queries("inverse-kinematics", [(["b1", _pose(1.4, 1.4, 0), None], ctx)])
    assert far.r_s[0] > near.r_s[0]
    with pytest.raises(ValueError, match="features"):
        model.predict("inverse-kinematics", rows[:, :-1])


def test_split_is_by_run(trained: tuple[CostModel, TrainReport], data: list[QueryRecord]) -> None:
    _, report = trained
    runs = {r.run_id for r in data}
    assert set(report.train_runs).isdisjoint(report.val_runs)
    assert set(report.train_runs) | set(report.val_runs) == runs
    assert len(report.val_runs) == 8  # 20% of 40 runs
    again = split_runs(runs, val_fraction=0.2, seed=0)
    assert again == (report.train_runs, report.val_runs)
    assert split_runs(runs, val_fraction=0.2, seed=1) != again
    counts = report.stream("inverse-kinematics")
    assert (counts.n_train, counts.n_val) == (32 * 8, 8 * 8)


def test_too_few_queries_gets_the_prior_and_a_warning(caplog: pytest.LogCaptureFixture) -> None:
    records = _Runs(10, seed=3, grasp_runs=4).records
    with caplog.at_level(logging.WARNING, logger="planner.learning.train"):
        model, report = train(records, domain=KITCHEN, seed=0, epochs=5, min_queries=30)
    warned = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any("sample-grasp" in m and "min_queries=30" in m for m in warned)
    assert report.stream("sample-grasp").prior_used
    assert "sample-grasp" not in model.networks
    prior = model.priors["sample-grasp"]
    n = report.stream("sample-grasp").n_train
    assert n > 0
    assert prior.p_s == pytest.approx((n + 1) / (n + 2))  # all succeed, Laplace-smoothed
    rows = np.zeros((3, model.featurizer.width("sample-grasp")), dtype=np.float32)
    pred = model.predict("sample-grasp", rows)
    assert pred.p_s.tolist() == [prior.p_s] * 3
    assert pred.r_s == pytest.approx([5e-5] * 3)
    other = model.predict("never-seen", np.zeros((2, 7)))
    assert other.p_s.tolist() == [model.default_prior.p_s] * 2


def test_training_is_deterministic_given_the_seed(data: list[QueryRecord]) -> None:
    small = data[:200]
    a, _ = train(small, domain=KITCHEN, seed=5, epochs=20, min_queries=10)
    b, _ = train(small, domain=KITCHEN, seed=5, epochs=20, min_queries=10)
    c, _ = train(small, domain=KITCHEN, seed=6, epochs=20, min_queries=10)
    motions = [(r.inputs, r.context) for r in small if r.stream == "plan-motion"]
    rows = a.featurizer.matrix("plan-motion", motions)
    assert np.array_equal(a.predict("plan-motion", rows).r_m, b.predict("plan-motion", rows).r_m)
    assert not np.array_equal(
        a.predict("plan-motion", rows).r_m, c.predict("plan-motion", rows).r_m
    )


# --- the model file --------------------------------------------------------------------------


def test_save_and_load_give_identical_predictions(
    trained: tuple[CostModel, TrainReport], data: list[QueryRecord], tmp_path: Path
) -> None:
    model, _ = trained
    path = tmp_path / "models" / "kitchen.pt"
    model.save(path)
    loaded = CostModel.load(path, domain=KITCHEN)
    assert loaded.streams == model.streams
    assert loaded.metadata == model.metadata
    assert loaded.metadata["runs"] == 40 and loaded.metadata["seed"] == 0
    for stream in model.streams:
        ours = [(r.inputs, r.context) for r in data if r.stream == stream]
        rows = model.featurizer.matrix(stream, ours)
        assert np.array_equal(rows, loaded.featurizer.matrix(stream, ours))
        before, after = model.predict(stream, rows), loaded.predict(stream, rows)
        for field in ("p_s", "r_s", "r_f", "r_m"):
            assert np.array_equal(getattr(before, field), getattr(after, field)), (stream, field)


def _rewrite(path: Path, **changes: Any) -> None:
    payload = torch.load(path, weights_only=True)
    for key, value in changes.items():
        if key == "feature_version":
            payload["feature_spec"]["version"] = value
        else:
            payload[key] = value
    torch.save(payload, path)


def test_loading_the_wrong_file_names_the_mismatch(
    trained: tuple[CostModel, TrainReport], tmp_path: Path
) -> None:
    model, _ = trained
    path = tmp_path / "model.pt"
    model.save(path)
    with pytest.raises(ModelError, match="model trained for domain 'kitchen', this is 'line'"):
        CostModel.load(path, domain=load_domain("line"))

    _rewrite(path, feature_version=FEATURE_VERSION + 1)
    with pytest.raises(ModelError, match=f"feature version {FEATURE_VERSION + 1}"):
        CostModel.load(path, domain=KITCHEN)

    model.save(path)
    _rewrite(path, domain="blocksworld")
    with pytest.raises(ModelError, match="trained for domain 'blocksworld', this is 'kitchen'"):
        CostModel.load(path, domain=KITCHEN)

    missing = tmp_path / "nope.pt"
    with pytest.raises(ModelError, match=str(missing)):
        CostModel.load(missing, domain=KITCHEN)

    text = tmp_path / "notes.pt"
    text.write_text("not a model")
    with pytest.raises(ModelError, match="not a cost-model file"):
        CostModel.load(text, domain=KITCHEN)
    torch.save({"weights": torch.zeros(3)}, text)
    with pytest.raises(ModelError, match="not a cost-model file"):
        CostModel.load(text, domain=KITCHEN)


def test_a_store_recorded_without_geometry_gets_it_from_the_runs_scene(tmp_path: Path) -> None:
    """Stores written before queries carried their scene's static context still train the
    same model: loading fills it in from the run's scene (kitchen-1's 22 cm stove)."""
    from planner.domains.kitchen.features import room_left
    from planner.events import StreamQueried
    from planner.learning.train import load_records
    from planner.store import RunStore

    db = tmp_path / "old.db"
    with RunStore(db) as store:
        run_id = store.create_run("kitchen-1", 0, "baseline", {})
        old_context = {"facts": [["holding", "b1", "g1"]], "values": {}}
        store.write_events(
            run_id,
            [
                StreamQueried(
                    run_id=run_id,
                    seq=0,
                    t=0.1,
                    node_id=2,
                    stream="sample-placement",
                    input_names=["b1", "stove"],
                    inputs=["b1", "stove"],
                    success=True,
                    wall_s=0.001,
                    cpu_s=0.001,
                    execution_s=0.0,
                    error=None,
                    context=old_context,
                )
            ],
        )
    (record,) = load_records([db])
    assert record.context["facts"] == old_context["facts"]
    assert record.context["geometry"]["platforms"]["stove"] == pytest.approx(
        [-0.11, 0.11, -1.26, -1.04]
    )
    assert room_left("b1", "stove", record.context) == [0.0, 30.0, 0.0]  # an empty stove
