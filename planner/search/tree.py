"""The search tree as plain data: nodes in a list, addressed by id.

Root (id 0) -> one node per stream plan (depth 0, nothing bound) -> one node per query result of
that plan's next stream. A node at depth d has the plan's first d streams bound; a failed query
is a leaf that records the failure.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

ROOT = 0


@dataclass
class Node:
    id: int
    parent: int | None
    plan_index: int  # -1 for the root
    depth: int  # streams bound along the path (plan nodes: 0)
    success: bool = True  # False: a failed query (a leaf)
    outputs: dict[str, Any] = field(default_factory=dict)  # optimistic object -> value
    children: list[int] = field(default_factory=list)
    visits: int = 0
    value: float = 0.0
    query_wall_s: float = 0.0  # seconds of the query that made this node
    execution_s: float = 0.0  # seconds the robot will take to execute what that query bound
    # Its stream said it will find nothing more here (Failure.exhausted): no more queries.
    exhausted: bool = False
    # Exhausted and nothing live below it: the search never comes here again.
    dead: bool = False
    # Its next query was a known failure (TreeSearch.memo_exhausted): answered without a query.
    known_failure: bool = False


@dataclass
class Tree:
    nodes: list[Node] = field(default_factory=list)
    plan_nodes: dict[int, int] = field(default_factory=dict)  # plan index -> node id

    def __post_init__(self) -> None:
        if not self.nodes:
            self.nodes.append(Node(ROOT, None, -1, 0))

    def add(
        self,
        parent: int,
        *,
        plan_index: int,
        depth: int,
        success: bool,
        outputs: dict[str, Any] | None = None,
        query_wall_s: float = 0.0,
        execution_s: float = 0.0,
    ) -> Node:
        node = Node(
            len(self.nodes),
            parent,
            plan_index,
            depth,
            success,
            outputs or {},
            [],
            0,
            0.0,
            query_wall_s,
            execution_s,
        )
        self.nodes.append(node)
        self.nodes[parent].children.append(node.id)
        if parent == ROOT:
            self.plan_nodes[plan_index] = node.id
        return node

    def __getitem__(self, node_id: int) -> Node:
        return self.nodes[node_id]

    def __len__(self) -> int:
        return len(self.nodes)

    def path(self, node_id: int) -> list[int]:
        """Ids from the root to ``node_id``."""
        out = []
        current: int | None = node_id
        while current is not None:
            out.append(current)
            current = self.nodes[current].parent
        return out[::-1]

    def bindings(self, node_id: int) -> dict[str, Any]:
        """Every optimistic object bound on the way to ``node_id``."""
        values: dict[str, Any] = {}
        for i in self.path(node_id):
            values.update(self.nodes[i].outputs)
        return values

    def live_children(self, node_id: int) -> list[Node]:
        """Children a search may still descend into: bound (not failed) and not dead."""
        nodes = self.nodes
        return [nodes[c] for c in nodes[node_id].children if nodes[c].success and not nodes[c].dead]
