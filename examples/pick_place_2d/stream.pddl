; The streams of the 2-D pick-and-place, bound in domain.py to the samplers of primitives.py by
; PDDLStream's adapters (planner.streams.pddlstream).
(define (stream pick-place-2d)
  ; A placement of the block inside the region, drawn uniformly (it does not look at the
  ; others: the collision test below does).
  (:stream sample-pose
    :inputs (?b ?r)
    :domain (Placeable ?b ?r)
    :outputs (?p)
    :certified (and (Pose ?b ?p) (Contained ?b ?p ?r)))

  ; Where along its top the gripper may hold the block: a short list of offsets.
  (:stream sample-grasp
    :inputs (?b)
    :domain (Block ?b)
    :outputs (?g)
    :certified (Grasp ?b ?g))

  ; The gripper configuration holding the block at ?p by ?g, if the arm reaches it.
  (:stream inverse-kinematics
    :inputs (?b ?p ?g)
    :domain (and (Pose ?b ?p) (Grasp ?b ?g))
    :outputs (?q)
    :certified (and (Conf ?q) (Kin ?b ?p ?g ?q)))

  ; Up to the travel height, across, and down: a trajectory between two configurations.
  (:stream plan-motion
    :inputs (?q1 ?q2)
    :domain (and (Conf ?q1) (Conf ?q2))
    :outputs (?t)
    :certified (and (Traj ?t) (Motion ?q1 ?t ?q2)))

  ; Two blocks at these poses do not overlap.
  (:stream test-cfree
    :inputs (?b1 ?p1 ?b2 ?p2)
    :domain (and (Pose ?b1 ?p1) (Pose ?b2 ?p2))
    :certified (CFree ?b1 ?p1 ?b2 ?p2))

  ; How far the gripper travels between two configurations.
  (:function (Dist ?q1 ?q2)
    (and (Conf ?q1) (Conf ?q2)))
)
