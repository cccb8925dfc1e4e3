; The gripper takes blocks and tools alike: parameters of type (either block tool). A fixture
; is an object too, but of neither type: no plan may pick it, even where every other
; precondition holds for it.
(define (domain either)
  (:requirements :strips :typing)
  (:types block tool fixture pose region)
  (:predicates
    (region ?r - region)
    (movable ?o)
    (pose ?o ?p - pose)
    (contained ?o ?p - pose ?r - region)
    (at ?o ?p - pose)
    (in ?o ?r - region)
    (holding ?o - (either block tool))
    (hand-empty))

  (:action pick
    :parameters (?o - (either block tool) ?p - pose ?r - region)
    :precondition (and (at ?o ?p) (in ?o ?r) (hand-empty))
    :effect (and (holding ?o) (not (at ?o ?p)) (not (in ?o ?r)) (not (hand-empty))))

  (:action place
    :parameters (?o - (either block tool) ?p - pose ?r - region)
    :precondition (and (holding ?o) (contained ?o ?p ?r))
    :effect (and (at ?o ?p) (in ?o ?r) (hand-empty) (not (holding ?o))))
)
