(define (stream tower)
  ; Where on top of ?c the block ?b goes (relative to ?c's centre).
  (:stream sample-offset
    :inputs (?b ?c)
    :domain (and (block ?b) (block ?c))
    :outputs (?o - offset)
    :certified (offset ?b ?c ?o))

  ; The block does not tip over at that offset.
  (:stream test-stable
    :inputs (?b ?c ?o)
    :domain (offset ?b ?c ?o)
    :certified (stable ?b ?c ?o))
)
