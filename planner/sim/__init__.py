"""The pybullet world.

Public modules (imported explicitly, so ``python -m planner.sim.pr2_model`` runs cleanly and
the pure-geometry helpers do not load the IK solver):

- :mod:`planner.sim.pr2_model`: the generated PR2 URDF (``scenes/pr2.urdf``), joint names,
  limits, velocity limits, rest arm poses.
- :mod:`planner.sim.ik`: ``arm_ik`` / ``arm_fk``, PR2 IKFast with joint-limit filtering.
"""

__all__ = ["ik", "pr2_model"]
