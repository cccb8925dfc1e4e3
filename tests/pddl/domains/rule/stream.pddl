(define (stream rule)
  (:stream sample-pose
    :inputs (?b ?r)
    :domain (and (movable ?b) (region ?r))
    :outputs (?p - pose)
    :certified (and (pose ?b ?p) (contained ?b ?p ?r)))

  ; A pose inside a target region is a goal pose: no sampler, it follows.
  (:rule
    :inputs (?b ?p ?r)
    :domain (and (contained ?b ?p ?r) (target ?r))
    :certified (goal-pose ?b ?p))

  ; The gripper reaches the goal pose.
  (:stream test-reachable
    :inputs (?b ?p)
    :domain (goal-pose ?b ?p)
    :certified (reachable ?p))
)
