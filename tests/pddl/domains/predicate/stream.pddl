(define (stream predicate)
  (:stream sample-pose
    :inputs (?b ?r)
    :domain (and (movable ?b) (region ?r))
    :outputs (?p - pose)
    :certified (and (pose ?b ?p) (contained ?b ?p ?r)))

  ; The blocks at these positions overlap (Python, evaluated only where a plan needs it).
  (:predicate (collide ?b ?p ?b2 ?p2)
    (and (pose ?b ?p) (pose ?b2 ?p2)))
)
