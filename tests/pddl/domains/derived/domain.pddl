; Blocks on a line are moved into a narrow goal region. A block may be put down only where it
; collides with no block standing elsewhere: PDDLStream's "unsafe pose" pattern, a derived
; predicate over a test stream's facts. Placing needs (not (unsafe ...)), so the stream plan
; must test the new pose against every block standing at that point of the plan.
(define (domain derived)
  (:requirements :strips :typing :negative-preconditions :equality :derived-predicates
                 :existential-preconditions)
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
    (unsafe ?b - block ?p - pose))

  (:derived (unsafe ?b - block ?p - pose)
    (exists (?b2 - block ?p2 - pose)
      (and (at ?b2 ?p2) (not (= ?b ?b2)) (not (cfree ?b ?p ?b2 ?p2)))))

  (:action pick
    :parameters (?b - block ?p - pose ?r - region)
    :precondition (and (at ?b ?p) (in ?b ?r) (hand-empty))
    :effect (and (holding ?b) (not (at ?b ?p)) (not (in ?b ?r)) (not (hand-empty))))

  (:action place
    :parameters (?b - block ?p - pose ?r - region)
    :precondition (and (holding ?b) (contained ?b ?p ?r) (not (unsafe ?b ?p)))
    :effect (and (at ?b ?p) (in ?b ?r) (hand-empty) (not (holding ?b))))
)
