; A test domain for the model's stream order: an item is prepared with a value that is dear to
; sample but always found, then finished with one that is cheap to sample but rarely found.
(define (domain order)
  (:requirements :strips)
  (:predicates (item ?i) (dear ?i ?v) (cheap ?i ?w) (prepared ?i) (finished ?i))
  (:action prepare
    :parameters (?i ?v)
    :precondition (and (item ?i) (dear ?i ?v))
    :effect (prepared ?i))
  (:action finish
    :parameters (?i ?w)
    :precondition (and (prepared ?i) (cheap ?i ?w))
    :effect (finished ?i))
)
