; A walk of four steps, each step's point drawn by a stream: the dashboard's tests pace it.
(define (domain paced)
  (:requirements :strips)
  (:predicates (point ?p) (step ?a ?b) (next ?l1 ?l2) (at ?l ?p) (reached ?l))

  (:action advance
    :parameters (?l1 ?l2 ?a ?b)
    :precondition (and (next ?l1 ?l2) (at ?l1 ?a) (step ?a ?b))
    :effect (and (at ?l2 ?b) (reached ?l2) (not (at ?l1 ?a))))
)
