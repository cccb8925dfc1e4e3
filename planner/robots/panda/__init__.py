"""The Franka Panda of pybullet_data, a fixed-base 7-DOF arm with a parallel gripper
(docs/panda.md).

- :mod:`planner.robots.panda.model`: joint names, limits and velocities, the hand's geometry,
  the ready pose, where pybullet_data keeps its URDF;
- :mod:`planner.robots.panda.visuals`: the URDF the 3D view draws (flat-coloured, decimated
  meshes, written to the mesh cache on first use) and a URDF's forward kinematics.

``robot.ROBOT`` is what the registry hands out. Its URDF and meshes are pybullet_data's,
installed with pybullet; nothing is read from the repository.
"""
