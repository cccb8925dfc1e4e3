"""The PR2, generated from its published dimensions, with IKFast arms (docs/sim.md).

- :mod:`planner.robots.pr2.dimensions`: links, dimensions and colours the model and the meshes
  are built from;
- :mod:`planner.robots.pr2.model`: the model (joint names, limits, velocity limits, rest arm
  poses) and the generator of ``pr2.urdf`` and ``meshes/`` in this package
  (``python -m planner.robots.pr2.model --write``);
- :mod:`planner.robots.pr2.visuals`: what the drawn meshes look like (trimesh, only the
  generator needs it);
- :mod:`planner.robots.pr2.ik`: ``arm_ik`` / ``arm_fk``, PR2 IKFast with joint-limit filtering.

``robot.ROBOT`` is what the registry hands out. The URDF and its meshes are package data: they
ship in the wheel and are read from here.
"""
