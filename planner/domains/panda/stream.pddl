; Streams of the Panda tabletop: each wraps a real sampler or solver (samplers.py).
(define (stream panda)
  ; A top grasp of the block: the hand points down, its fingers close across two faces.
  (:stream sample-grasp
    :inputs (?b)
    :domain (block ?b)
    :outputs (?g)
    :certified (grasp ?b ?g))

  ; A pose of the block in a region where it may go, clear of the blocks already there.
  (:stream sample-placement
    :inputs (?b ?r)
    :domain (placeable ?b ?r)
    :outputs (?p)
    :certified (and (pose ?b ?p) (supported ?b ?p ?r)))

  ; Joint angles that hold the block at ?p with grasp ?g, and the same hand raised above it,
  ; the straight move between them clear of the table and the other blocks (IK with restarts).
  (:stream inverse-kinematics
    :inputs (?b ?p ?g)
    :domain (and (pose ?b ?p) (grasp ?b ?g))
    :outputs (?q)
    :certified (and (conf ?q) (kin ?b ?p ?g ?q)))

  ; A collision-free joint-space trajectory between two configurations (OMPL RRT-Connect, 7-D),
  ; with the held block attached to the hand.
  (:stream plan-motion
    :inputs (?q1 ?q2)
    :domain (and (conf ?q1) (conf ?q2))
    :outputs (?t)
    :certified (and (traj ?t) (motion ?q1 ?t ?q2)))
)
