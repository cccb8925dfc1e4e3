"""Write a small store (argument: a path or URL) with the planner on sys.path, an old checkout:
two runs of line-2, one solved and one left running, and a benchmark with one trial."""

import sys

from planner.events import Emitter, NodeAdded, NodeVisited, RunFinished, RunStarted, StreamQueried
from planner.store import BenchTrialRecord, RunStore, StoreSink

url = sys.argv[1]
store = RunStore(url)
for seed, status in ((1, "solved"), (2, None)):
    run_id = store.create_run("line-2", seed, "baseline", {"budget_s": 60.0})
    sink = StoreSink(store, run_id)
    em = Emitter(run_id, sink)
    em.emit(RunStarted, scene="line-2", seed=seed, planner="baseline", config={"budget_s": 60.0})
    for i in range(3):
        em.emit(
            NodeAdded,
            node_id=i + 1,
            parent_id=i,
            plan_index=0,
            depth=i + 1,
            stream="sample-pose",
            success=True,
            outputs=[f"#p{i}"],
            label=f"node {i + 1}",
        )
        em.emit(
            StreamQueried,
            node_id=i + 1,
            stream="sample-pose",
            input_names=["?b", "?r"],
            inputs=["b1", [0.0, 1.0]],
            success=i != 1,
            wall_s=0.01,
            cpu_s=0.01,
            execution_s=0.0,
            error=None,
        )
        em.emit(NodeVisited, node_id=i + 1, visits=1, value=-1.0)
    if status:
        em.emit(
            RunFinished,
            status="solved",
            planning_s=1.5,
            execution_s=2.0,
            oracle_s=0.5,
            queries=3,
            message="",
        )
    sink.close()
    if status:
        store.finish_run(run_id, "solved", planning_s=1.5, execution_s=2.0, oracle_s=0.5, queries=3)
bench = store.create_bench(
    {"scene": "line-2", "planners": ["baseline"], "seeds": [1, 2], "budget_s": 60.0}
)
store.record_trial(
    BenchTrialRecord(bench, 1, "baseline", None, "solved", True, 1.5, 2.0, 0.5, 3, None)
)
store.set_bench_status(bench, "done")
store.close()
print(bench)
