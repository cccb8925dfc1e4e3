(define (stream disjunction)
  (:stream sample-pose
    :inputs (?b ?r)
    :domain (and (movable ?b) (region ?r))
    :outputs (?p - pose)
    :certified (and (pose ?b ?p) (contained ?b ?p ?r)))

  ; The left arm reaches the pose.
  (:stream test-left
    :inputs (?b ?p)
    :domain (pose ?b ?p)
    :certified (reach-left ?p))

  ; The right arm reaches the pose.
  (:stream test-right
    :inputs (?b ?p)
    :domain (pose ?b ?p)
    :certified (reach-right ?p))
)
