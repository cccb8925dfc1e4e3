"""The pybullet world, knowing no particular robot or domain (robots are in
:mod:`planner.robots`).

Public modules (imported explicitly, so the pure-geometry helpers load neither pybullet nor
trimesh):

- :mod:`planner.sim.bodies`: pybullet bodies, poses and contact queries (explicit client ids).
- :mod:`planner.sim.collision`: does a robot (and what it holds) come within a margin of
  anything: exact pybullet answers behind a broad phase and a filter of self pairs.
- :mod:`planner.sim.motion`: OMPL RRT-Connect for a mobile base (SE(2)) and an arm (joints).
- :mod:`planner.sim.meshes`: simple shapes as triangle meshes, written as OBJ files.
- :mod:`planner.sim.render`: a domain's scene description as a PNG (pybullet's renderer).
- :mod:`planner.sim.transforms`: poses as (position, xyzw quaternion); ``to_wxyz`` for viser.
"""

__all__ = ["bodies", "collision", "meshes", "motion", "render", "transforms"]
