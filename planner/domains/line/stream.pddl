(define (stream line)
  ; A position of the block inside the region.
  (:stream sample-pose
    :inputs (?b ?r)
    :domain (and (movable ?b) (region ?r))
    :outputs (?p - pose)
    :certified (and (valid ?b ?p) (contained ?b ?p ?r)))

  ; A test: the gripper reaches the position.
  (:stream test-reachable
    :inputs (?b ?p)
    :domain (valid ?b ?p)
    :certified (reachable ?p))
)
