(define (stream safe)
  ; A position of the block inside the region.
  (:stream sample-pose
    :inputs (?b ?r)
    :domain (and (movable ?b) (region ?r))
    :outputs (?p - pose)
    :certified (and (pose ?b ?p) (contained ?b ?p ?r)))

  ; The two blocks at these positions do not overlap.
  (:stream test-cfree
    :inputs (?b ?p ?b2 ?p2)
    :domain (and (pose ?b ?p) (pose ?b2 ?p2))
    :certified (cfree ?b ?p ?b2 ?p2))
)
