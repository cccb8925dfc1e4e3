"""The pybullet world.

Public modules (imported explicitly, so ``python -m planner.sim.pr2_model`` runs cleanly and
the pure-geometry helpers do not load the IK solver):

- :mod:`planner.sim.pr2_model`: the generated PR2 URDF (``scenes/pr2.urdf``), joint names,
  limits, velocity limits, rest arm poses.
- :mod:`planner.sim.ik`: ``arm_ik`` / ``arm_fk``, PR2 IKFast with joint-limit filtering.
- :mod:`planner.sim.bodies`: pybullet bodies, poses and contact queries (explicit client ids).
- :mod:`planner.sim.collision`: does a robot (and what it holds) come within a margin of
  anything: exact pybullet answers behind a broad phase and a filter of self pairs.
- :mod:`planner.sim.motion`: OMPL RRT-Connect for the base (SE(2)) and an arm (joint space).
- :mod:`planner.sim.transforms`: poses as (position, xyzw quaternion); ``to_wxyz`` for viser.
"""

__all__ = ["bodies", "collision", "ik", "motion", "pr2_model", "transforms"]
