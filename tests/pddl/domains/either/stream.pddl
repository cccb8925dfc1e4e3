(define (stream either)
  (:stream sample-pose
    :inputs (?o ?r)
    :domain (and (movable ?o) (region ?r))
    :outputs (?p - pose)
    :certified (and (pose ?o ?p) (contained ?o ?p ?r)))
)
