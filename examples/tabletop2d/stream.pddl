; The streams of the 2-D tabletop; each is bound to a Python sampler in samplers.py.
(define (stream tabletop2d)
  ; Where the gripper holds the block: an offset along the block's width.
  (:stream sample-grasp
    :inputs (?b)
    :domain (block ?b)
    :outputs (?g)
    :certified (grasp ?b ?g))

  ; A position of the block inside the region, drawn uniformly (it does not look at the others).
  (:stream sample-pose
    :inputs (?b ?r)
    :domain (and (block ?b) (region ?r))
    :outputs (?p)
    :certified (and (pose ?b ?p) (contained ?b ?p ?r)))

  ; A collision test: the block at ?p overlaps none of the blocks in ?r where it is placed.
  (:stream test-cfree
    :inputs (?b ?p ?r)
    :domain (contained ?b ?p ?r)
    :certified (cfree ?b ?p ?r))

  ; The gripper configuration that holds the block at ?p with grasp ?g, if the arm reaches it.
  (:stream inverse-kinematics
    :inputs (?b ?p ?g)
    :domain (and (pose ?b ?p) (grasp ?b ?g))
    :outputs (?q)
    :certified (and (conf ?q) (kin ?b ?p ?g ?q)))

  ; A straight path of the gripper between two configurations.
  (:stream plan-motion
    :inputs (?q1 ?q2)
    :domain (and (conf ?q1) (conf ?q2))
    :outputs (?t)
    :certified (and (path ?t) (motion ?q1 ?t ?q2)))
)
