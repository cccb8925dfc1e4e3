(define (stream costs)
  (:stream sample-grasp
    :inputs (?b)
    :domain (block ?b)
    :outputs (?g - grasp)
    :certified (grip ?b ?g))
)
