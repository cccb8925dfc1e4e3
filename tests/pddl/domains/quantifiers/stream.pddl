(define (stream quantifiers)
  (:stream sample-pose
    :inputs (?b ?r)
    :domain (and (movable ?b) (region ?r))
    :outputs (?p - pose)
    :certified (and (pose ?b ?p) (contained ?b ?p ?r)))

  ; A grasp of the block (the sampler finds one half the time).
  (:stream sample-grasp
    :inputs (?b)
    :domain (movable ?b)
    :outputs (?g - grasp)
    :certified (grip ?b ?g))

  (:stream test-cfree
    :inputs (?b ?p ?b2 ?p2)
    :domain (and (pose ?b ?p) (pose ?b2 ?p2))
    :certified (cfree ?b ?p ?b2 ?p2))
)
