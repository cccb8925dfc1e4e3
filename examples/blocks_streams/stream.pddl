; The streams of the blocksworld, bound in domain.py to primitives.py with PDDLStream's adapters.
(define (stream blocks-streams)
  ; A block may stand on another no wider than it that is not fragile.
  (:stream test-stackable
    :inputs (?b ?y)
    :domain (and (Block ?b) (Block ?y))
    :certified (Stackable ?b ?y))

  ; A block fits in a table slot at least as wide as it.
  (:stream test-fits
    :inputs (?b ?s)
    :domain (and (Block ?b) (Slot ?s))
    :certified (Stackable ?b ?s))

  ; Lift ?b from the top of ?x, carry it at the travel height and set it down on ?y: where
  ; ?x and ?y are depends on the stacks (the On facts), and the arm cannot hold a heavy
  ; block far from its base.
  (:stream plan-carry
    :inputs (?b ?x ?y)
    :domain (and (Block ?b) (Support ?x) (Support ?y))
    :fluents (On)
    :outputs (?t)
    :certified (and (Traj ?t) (Carry ?b ?x ?y ?t)))
)
