; The streams of the grid TAMP, bound in domain.py to the samplers of primitives.py by PDDLStream's
; adapters (planner.streams.pddlstream).
(define (stream grid-tamp)
  ; Every target cell of the goal is a pose a block may take (a rule: no sampler, its fact
  ; follows from its domain).
  (:rule
    :inputs (?p)
    :domain (Target ?p)
    :certified (Pose ?p))

  ; A cell of the grid, drawn uniformly: a stream with no inputs.
  (:stream sample-pose
    :outputs (?p)
    :certified (Pose ?p))

  ; The gripper configuration over a cell, if the arm reaches it.
  (:stream inverse-kinematics
    :inputs (?p)
    :domain (Pose ?p)
    :outputs (?q)
    :certified (and (Conf ?q) (Kin ?q ?p)))

  ; A path of cells between two configurations (a plain list, as PDDLStream's trajectories).
  (:stream plan-motion
    :inputs (?q1 ?q2)
    :domain (and (Conf ?q1) (Conf ?q2))
    :outputs (?t)
    :certified (Motion ?q1 ?t ?q2))

  ; Two cells are not the same cell.
  (:stream test-cfree
    :inputs (?p1 ?p2)
    :domain (and (Pose ?p1) (Pose ?p2))
    :certified (CFree ?p1 ?p2))
)
