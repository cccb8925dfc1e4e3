(define (stream fluents)
  ; A position in the region where the block overlaps no block standing at that point of the
  ; plan: the sampler gets those facts as fluents=[("at", block, pose), ...].
  (:stream sample-free-pose
    :inputs (?b ?r)
    :domain (and (movable ?b) (region ?r))
    :fluents (at)
    :outputs (?p - pose)
    :certified (and (pose ?b ?p) (contained ?b ?p ?r)))
)
