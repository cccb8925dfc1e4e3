"""How long a base move round the fixtures takes, cheaply: for ordering IK's base poses.

A straight line from where the robot stands to a base pose on the far side of the sink or the
table looks short, but the move has to go round the fixture: such moves took three to four
times their straight-line seconds in the benchmarks. :class:`BaseRoutes` gives the length of the
shortest path in the plane that keeps the base's centre a radius away from every fixture's
footprint (a visibility graph over the corners of the footprints grown into octagons, Dijkstra
from the start, over two dozen corners), and from it the seconds of the move under the
base's velocity limits. It knows the detour a straight line ignores; it knows nothing of the
blocks or the arm, and a planned move is still longer (the motion planner's paths are not
shortest).
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Sequence

from planner.sim.transforms import wrap_angle

Rect = tuple[float, float, float, float]  # xmin, xmax, ymin, ymax
Point = tuple[float, float]
Polygon = tuple[Point, ...]  # convex, counter-clockwise

_EPS = 1e-9


def grown(rect: Rect, radius: float, *, outer: bool = False) -> Polygon:
    """``rect`` grown by ``radius`` into an octagon, its corners cut at 45 degrees, against the
    rectangle's round-cornered Minkowski sum with a disc: inside it (the cuts are chords of the
    corner arcs), or with ``outer`` round it (the cuts are tangents)."""
    x0, x1, y0, y1 = rect
    r = radius
    c = r * math.tan(math.pi / 8) if outer else 0.0  # how far the cuts start from the sides
    return (
        (x0 - c, y0 - r),
        (x1 + c, y0 - r),
        (x1 + r, y0 - c),
        (x1 + r, y1 + c),
        (x1 + c, y1 + r),
        (x0 - c, y1 + r),
        (x0 - r, y1 + c),
        (x0 - r, y0 - c),
    )


def _edges(poly: Polygon) -> list[tuple[Point, Point]]:
    """(a point on the edge, its outward normal) of every edge."""
    out = []
    for (ax, ay), (bx, by) in zip(poly, poly[1:] + poly[:1], strict=True):
        out.append(((ax, ay), (by - ay, ax - bx)))
    return out


def _inside(p: Point, edges: list[tuple[Point, Point]]) -> bool:
    """Whether ``p`` lies strictly inside the polygon of ``edges``."""
    return all(n[0] * (p[0] - v[0]) + n[1] * (p[1] - v[1]) < -_EPS for v, n in edges)


def _crosses(a: Point, b: Point, edges: list[tuple[Point, Point]]) -> bool:
    """Whether the segment ``a``-``b`` passes through the open interior of the convex polygon
    of ``edges`` (sliding along an edge or touching a corner does not count)."""
    t0, t1 = 0.0, 1.0
    d = (b[0] - a[0], b[1] - a[1])
    for v, n in edges:
        num = n[0] * (a[0] - v[0]) + n[1] * (a[1] - v[1]) + _EPS
        den = n[0] * d[0] + n[1] * d[1]
        if abs(den) < 1e-15:
            if num >= 0:
                return False
            continue
        t = -num / den
        if den < 0:
            t0 = max(t0, t)
        else:
            t1 = min(t1, t)
        if t0 >= t1:
            return False
    return t1 - t0 > _EPS


def _nearest_on_boundary(p: Point, poly: Polygon) -> Point:
    """The point of ``poly``'s boundary nearest ``p``."""
    best, best_d = poly[0], math.inf
    for a, b in zip(poly, poly[1:] + poly[:1], strict=True):
        dx, dy = b[0] - a[0], b[1] - a[1]
        t = ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / ((dx * dx + dy * dy) or 1.0)
        t = min(1.0, max(0.0, t))
        q = (a[0] + t * dx, a[1] + t * dy)
        d = math.dist(p, q)
        if d < best_d:
            best, best_d = q, d
    return best


class BaseRoutes:
    """Shortest base routes round axis-aligned fixtures.

    Routes keep ``radius`` from every footprint: more than the base's half width (``tight``),
    since the square base, turned, reaches further, and a gap a base fits through only squarely
    is one the motion planner rarely finds. A pose nearer a fixture than ``radius`` (IK's often
    are) is reached from the nearest point outside. Two poses a straight line joins that clears
    every footprint by ``tight`` are joined by it.
    """

    def __init__(
        self,
        footprints: Sequence[Rect],
        radius: float,
        *,
        tight: float,
        velocity: tuple[float, float],
    ) -> None:
        if not 0 <= tight <= radius:
            raise ValueError(f"need 0 <= tight <= radius, got tight {tight}, radius {radius}")
        self.polygons: tuple[Polygon, ...] = tuple(grown(r, radius, outer=True) for r in footprints)
        self._edges = [_edges(p) for p in self.polygons]
        self._tight = [_edges(grown(r, tight)) for r in footprints]
        self.linear, self.angular = velocity
        corners: list[Point] = []
        for poly in self.polygons:
            corners.extend(self._pushed_out(poly, c) for c in poly)
        # A corner inside another grown fixture is no way round anything.
        self.corners: tuple[Point, ...] = tuple(
            c for c in corners if not any(_inside(c, e) for e in self._edges)
        )
        # The corners' visibility graph does not depend on the route: built once.
        self._links: list[list[tuple[int, float]]] = [[] for _ in self.corners]
        for i, a in enumerate(self.corners):
            for j in range(i + 1, len(self.corners)):
                b = self.corners[j]
                if self._free(a, b):
                    self._links[i].append((j, math.dist(a, b)))
                    self._links[j].append((i, math.dist(a, b)))

    @staticmethod
    def _pushed_out(poly: Polygon, p: Point, push: float = 1e-6) -> Point:
        """``p`` on ``poly``'s boundary, moved a hair away from its centre (so it is outside)."""
        cx = sum(x for x, _ in poly) / len(poly)
        cy = sum(y for _, y in poly) / len(poly)
        norm = math.hypot(p[0] - cx, p[1] - cy) or 1.0
        return (p[0] + push * (p[0] - cx) / norm, p[1] + push * (p[1] - cy) / norm)

    def _free(self, a: Point, b: Point) -> bool:
        return not any(_crosses(a, b, e) for e in self._edges)

    def _outside(self, p: Point) -> tuple[Point, float]:
        """Where a route to or from ``p`` leaves the grown fixtures, and how far that is."""
        q, extra = p, 0.0
        for _ in range(len(self.polygons) + 1):
            holding = [i for i, e in enumerate(self._edges) if _inside(q, e)]
            if not holding:
                break
            poly = self.polygons[holding[0]]
            out = self._pushed_out(poly, _nearest_on_boundary(q, poly))
            extra += math.dist(q, out)
            q = out
        return q, extra

    def distances_from(self, start: Point) -> Callable[[Point], float]:
        """Metres of the shortest route from ``start`` to any point, as a function."""
        s, s_extra = self._outside(start)
        nodes = self.corners
        dist = [math.inf] * len(nodes)
        heap: list[tuple[float, int]] = []
        for i, c in enumerate(nodes):
            if self._free(s, c):
                dist[i] = s_extra + math.dist(s, c)
                heapq.heappush(heap, (dist[i], i))
        done = [False] * len(nodes)
        while heap:
            d, i = heapq.heappop(heap)
            if done[i]:
                continue
            done[i] = True
            for j, length in self._links[i]:
                if not done[j] and d + length < dist[j]:
                    dist[j] = d + length
                    heapq.heappush(heap, (dist[j], j))

        def to(goal: Point) -> float:
            if not any(_crosses(start, goal, e) for e in self._tight):
                return math.dist(start, goal)
            g, g_extra = self._outside(goal)
            if self._free(s, g):
                return s_extra + math.dist(s, g) + g_extra
            best = math.inf
            for i, c in enumerate(nodes):
                if dist[i] + g_extra < best and self._free(c, g):
                    best = min(best, dist[i] + math.dist(c, g) + g_extra)
            # Shut in where grown fixtures overlap (the base itself may fit): the straight line.
            return best if best < math.inf else math.dist(start, goal)

        return to

    def seconds_from(
        self, start: tuple[float, float, float]
    ) -> Callable[[tuple[float, float, float]], float]:
        """Seconds of the move from the base pose ``start`` to any base pose, as a function: the
        route's length at the linear limit, or the turn at the angular one if that is longer."""
        metres = self.distances_from((start[0], start[1]))

        def seconds(goal: tuple[float, float, float]) -> float:
            turn = abs(wrap_angle(goal[2] - start[2])) / self.angular
            return max(metres((goal[0], goal[1])) / self.linear, turn)

        return seconds
