"""Probe: how close to a fixture the PR2's base, arms at rest, may stand, by its heading.

    .venv/bin/python benchmarks/base_extent.py

Puts the robot (arms at rest, the scene's torso height) west of kitchen-4's table, facing each
of 16 headings, and moves it in 1 cm steps from 0.30 m off the table's edge until it no longer
collides (with the motion planner's clearance). Prints the first clear distance per heading:
what ``SamplerConfig.route_radius`` is chosen between.
"""

from __future__ import annotations

import math
import random
import sys


def main() -> int:
    from planner.domains import problem_for_scene
    from planner.domains.kitchen import GEOMETRY_KEY
    from planner.domains.kitchen.samplers import KitchenSamplers
    from planner.domains.kitchen.values import Conf

    _, problem = problem_for_scene("kitchen-4", seed=0)
    geometry = problem.values[GEOMETRY_KEY]
    samplers = KitchenSamplers(geometry, random.Random(0))  # type: ignore[arg-type]
    try:
        edge = geometry.platform("table").footprint()[0]  # type: ignore[attr-defined]
        torso = geometry.robot.torso  # type: ignore[attr-defined]
        print("| heading (deg) | first clear distance from the table's edge (m) |")
        print("| --- | --- |")
        for k in range(16):
            yaw = k * math.pi / 8
            clear = None
            for step in range(30, 90):
                d = step / 100
                samplers.world.set_conf(Conf((edge - d, 0.0, yaw), torso, samplers.rest))
                if not samplers.world.robot_collides(clearance=samplers.config.clearance):
                    clear = d
                    break
            print(f"| {math.degrees(yaw):.1f} | {'> 0.89' if clear is None else f'{clear:.2f}'} |")
    finally:
        samplers.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
