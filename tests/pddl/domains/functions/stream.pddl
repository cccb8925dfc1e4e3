(define (stream functions)
  ; A configuration from which the block is in view.
  (:stream sample-view
    :inputs (?b)
    :domain (block ?b)
    :outputs (?q - conf)
    :certified (and (conf ?q) (kin ?b ?q)))

  ; How far apart two configurations are (Python: |x1 - x2|).
  (:function (dist ?q1 ?q2)
    (and (conf ?q1) (conf ?q2)))
)
