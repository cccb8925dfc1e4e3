(define (stream order)
  ; Dear (a few milliseconds) and never fails.
  (:stream sample-dear
    :inputs (?i)
    :domain (item ?i)
    :outputs (?v)
    :certified (dear ?i ?v))

  ; Cheap and fails three times in four.
  (:stream sample-cheap
    :inputs (?i)
    :domain (item ?i)
    :outputs (?w)
    :certified (cheap ?i ?w))
)
