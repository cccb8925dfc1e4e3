; Quantified conditions. Picking needs some grasp of the block ((exists ...) over a stream's
; outputs: the grasp is no parameter, so its stream comes in through the witness); placing
; needs the new pose clear of every block standing ((forall ... (imply ...))); the goal asks
; for every block in the goal region ((forall ...)).
(define (domain quantifiers)
  (:requirements :strips :typing :negative-preconditions :equality
                 :existential-preconditions :universal-preconditions)
  (:types block pose grasp region)
  (:predicates
    (movable ?b - block)
    (region ?r - region)
    (target ?r - region)
    (pose ?b - block ?p - pose)
    (contained ?b - block ?p - pose ?r - region)
    (grip ?b - block ?g - grasp)
    (cfree ?b - block ?p - pose ?b2 - block ?p2 - pose)
    (at ?b - block ?p - pose)
    (in ?b - block ?r - region)
    (holding ?b - block)
    (hand-empty))

  (:action pick
    :parameters (?b - block ?p - pose ?r - region)
    :precondition (and (at ?b ?p) (in ?b ?r) (hand-empty)
                       (exists (?g - grasp) (grip ?b ?g)))
    :effect (and (holding ?b) (not (at ?b ?p)) (not (in ?b ?r)) (not (hand-empty))))

  (:action place
    :parameters (?b - block ?p - pose ?r - region)
    :precondition (and (holding ?b) (contained ?b ?p ?r)
                       (forall (?b2 - block ?p2 - pose)
                         (imply (at ?b2 ?p2) (cfree ?b ?p ?b2 ?p2))))
    :effect (and (at ?b ?p) (in ?b ?r) (hand-empty) (not (holding ?b))))
)
