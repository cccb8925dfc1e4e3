"""Abstract planning: optimistic stream instances, top-k plans, and their stream plans."""

from planner.abstract.compile import (
    DEFAULT_COST_SCALE,
    FunctionEvaluator,
    PlannerTask,
    compile_planner_task,
)
from planner.abstract.errors import (
    AbstractPlanningError,
    InstantiationLimitError,
    PlannerTimeoutError,
    TopKPlannerError,
    UnreachableGoalError,
)
from planner.abstract.instantiate import (
    OPTIMISTIC_PREFIX,
    OptimisticInstantiation,
    StreamInstance,
    instantiate,
)
from planner.abstract.planner import (
    MAX_K,
    AbstractConfig,
    AbstractResult,
    compile_task,
    plan_abstract,
)
from planner.abstract.skeleton import (
    AbstractPlan,
    GroundAction,
    PlanReplayError,
    action_multiset,
    canonical_key,
    recover_stream_plan,
    replay,
    symbolic_states,
)
from planner.abstract.source import (
    DEFAULT_SOURCE,
    SKELETON_SOURCES,
    Feedback,
    SkeletonBatch,
    SkeletonSource,
)
from planner.abstract.topk import (
    DEFAULT_TOPK,
    TOPK_PLANNERS,
    KStarPlanner,
    SymKPlanner,
    TopKPlanner,
    TopKResult,
    get_topk_planner,
)

__all__ = [
    "DEFAULT_COST_SCALE",
    "DEFAULT_SOURCE",
    "DEFAULT_TOPK",
    "MAX_K",
    "OPTIMISTIC_PREFIX",
    "SKELETON_SOURCES",
    "TOPK_PLANNERS",
    "AbstractConfig",
    "AbstractPlan",
    "AbstractPlanningError",
    "AbstractResult",
    "Feedback",
    "FunctionEvaluator",
    "GroundAction",
    "InstantiationLimitError",
    "KStarPlanner",
    "OptimisticInstantiation",
    "PlanReplayError",
    "PlannerTask",
    "PlannerTimeoutError",
    "SkeletonBatch",
    "SkeletonSource",
    "StreamInstance",
    "SymKPlanner",
    "TopKPlanner",
    "TopKPlannerError",
    "TopKResult",
    "UnreachableGoalError",
    "action_multiset",
    "canonical_key",
    "compile_planner_task",
    "compile_task",
    "get_topk_planner",
    "instantiate",
    "plan_abstract",
    "recover_stream_plan",
    "replay",
    "symbolic_states",
]
