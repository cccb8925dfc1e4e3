; The next point of the walk; its sampler answers only when the test hands it a token.
(define (stream paced)
  (:stream sample-step
    :inputs (?a)
    :domain (point ?a)
    :outputs (?b)
    :certified (and (point ?b) (step ?a ?b)))
)
