; Streams of the kitchen: each wraps a real sampler or solver (grasps, placements, IK, motion).
(define (stream kitchen)
  ; A grasp of the block (top or side), relative to the block.
  (:stream sample-grasp
    :inputs (?b)
    :domain (block ?b)
    :outputs (?g)
    :certified (grasp ?b ?g))

  ; A stable pose of the block on a platform.
  (:stream sample-placement
    :inputs (?b ?r)
    :domain (and (block ?b) (platform ?r))
    :outputs (?p)
    :certified (and (pose ?b ?p) (supported ?b ?p ?r)))

  ; A base pose near the block and an arm configuration that holds it with the grasp.
  (:stream inverse-kinematics
    :inputs (?b ?p ?g)
    :domain (and (pose ?b ?p) (grasp ?b ?g))
    :outputs (?q)
    :certified (and (conf ?q) (kin ?b ?p ?g ?q)))

  ; A collision-free trajectory of base and arm between two configurations.
  (:stream plan-motion
    :inputs (?q1 ?q2)
    :domain (and (conf ?q1) (conf ?q2))
    :outputs (?t)
    :certified (and (traj ?t) (motion ?q1 ?t ?q2)))
)
