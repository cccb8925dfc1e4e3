"""The stream runtime: Python samplers bound to declared streams, timed queries."""

from planner.streams.adapters import (
    Failure,
    Last,
    StreamAdapter,
    StreamContext,
    from_fn,
    from_function,
    from_gen_fn,
    from_test,
)
from planner.streams.runtime import (
    BoundStream,
    FunctionValueError,
    QueryResult,
    StreamBindingError,
    StreamRuntime,
    bind_streams,
)

__all__ = [
    "BoundStream",
    "Failure",
    "FunctionValueError",
    "Last",
    "QueryResult",
    "StreamAdapter",
    "StreamBindingError",
    "StreamContext",
    "StreamRuntime",
    "bind_streams",
    "from_fn",
    "from_function",
    "from_gen_fn",
    "from_test",
]
