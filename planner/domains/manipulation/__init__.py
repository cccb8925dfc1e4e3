"""What the kitchen and the Panda share, written once: the code of a domain in which a simulated
robot (from :mod:`planner.robots`) moves blocks among fixtures and stands them upright. It is no
domain itself (no PDDL, no ``DOMAIN``); the kitchen and the Panda use it, and nothing else does
(tests/domains/test_shared_code.py):

- :mod:`~planner.domains.manipulation.problem`: an upright block's pose, a problem gathered from
  a scene (the robot's start facts, each block's ``block``, ``pose``, ``at-pose``, ``on``), the
  geometry a problem keeps, lookups by name;
- :mod:`~planner.domains.manipulation.domain`: the domain object's shared parts: the four
  streams' inputs, the samplers and the validator imported when first used, other samplers;
- :mod:`~planner.domains.manipulation.world`: the pybullet world of fixture boxes, blocks and
  the robot, the block in its hand, the obstacles kept until a block moves;
- :mod:`~planner.domains.manipulation.samplers`: the four streams around what a domain samples:
  the world set as a query's context says (``at-pose``, ``holding``), placements tried against
  the placed blocks; a sampler config set from text;
- :mod:`~planner.domains.manipulation.replay`: a bound plan replayed to validate it: the blocks,
  the hand and the seconds so far, the actions' values, the points checked along a path;
- :mod:`~planner.domains.manipulation.timeline`: a bound plan played in time for the 3D view;
- :mod:`~planner.domains.manipulation.view`: the blocks drawn, the ghosts of placements and
  grasps, the configuration a branch last bound;
- :mod:`~planner.domains.manipulation.props`: the tiled floor;
- :mod:`~planner.domains.manipulation.features`: numbers read from a recorded context.

pybullet and OMPL come in with ``world``, ``samplers`` and ``replay`` only: loading a domain
(its module, problems, view and features) imports neither.
"""
