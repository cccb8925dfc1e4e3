; The derived case written the other way round, as some PDDLStream domains do: a pose is safe
; for a block when every block standing elsewhere is clear of it, a derived predicate whose
; body is (forall ... (imply ...)). Placing needs (safe ...), so the stream plan must test the
; new pose against every block standing at that point of the plan.
(define (domain safe)
  (:requirements :strips :typing :negative-preconditions :equality :derived-predicates
                 :universal-preconditions)
  (:types block pose region)
  (:predicates
    (movable ?b - block)
    (region ?r - region)
    (pose ?b - block ?p - pose)
    (contained ?b - block ?p - pose ?r - region)
    (cfree ?b - block ?p - pose ?b2 - block ?p2 - pose)
    (at ?b - block ?p - pose)
    (in ?b - block ?r - region)
    (holding ?b - block)
    (hand-empty)
    (safe ?b - block ?p - pose))

  (:derived (safe ?b - block ?p - pose)
    (forall (?b2 - block ?p2 - pose)
      (imply (and (at ?b2 ?p2) (not (= ?b ?b2))) (cfree ?b ?p ?b2 ?p2))))

  (:action pick
    :parameters (?b - block ?p - pose ?r - region)
    :precondition (and (at ?b ?p) (in ?b ?r) (hand-empty))
    :effect (and (holding ?b) (not (at ?b ?p)) (not (in ?b ?r)) (not (hand-empty))))

  (:action place
    :parameters (?b - block ?p - pose ?r - region)
    :precondition (and (holding ?b) (contained ?b ?p ?r) (safe ?b ?p))
    :effect (and (at ?b ?p) (in ?b ?r) (hand-empty) (not (holding ?b))))
)
