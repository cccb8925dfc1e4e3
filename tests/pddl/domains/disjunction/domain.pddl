; Two arms: the left one reaches the left of the line, the right one the right. A block can be
; picked and placed by whichever arm reaches its pose ((or ...) in the preconditions); a fragile
; block may only go into a padded region ((imply ...)). The goal is a disjunction too.
(define (domain disjunction)
  (:requirements :strips :typing :negative-preconditions :disjunctive-preconditions)
  (:types block pose region)
  (:predicates
    (movable ?b - block)
    (region ?r - region)
    (fragile ?b - block)
    (padded ?r - region)
    (pose ?b - block ?p - pose)
    (contained ?b - block ?p - pose ?r - region)
    (reach-left ?p - pose)
    (reach-right ?p - pose)
    (at ?b - block ?p - pose)
    (in ?b - block ?r - region)
    (holding ?b - block)
    (hand-empty))

  (:action pick
    :parameters (?b - block ?p - pose ?r - region)
    :precondition (and (at ?b ?p) (in ?b ?r) (hand-empty)
                       (or (reach-left ?p) (reach-right ?p)))
    :effect (and (holding ?b) (not (at ?b ?p)) (not (in ?b ?r)) (not (hand-empty))))

  (:action place
    :parameters (?b - block ?p - pose ?r - region)
    :precondition (and (holding ?b) (contained ?b ?p ?r)
                       (or (reach-left ?p) (reach-right ?p))
                       (imply (fragile ?b) (padded ?r)))
    :effect (and (at ?b ?p) (in ?b ?r) (hand-empty) (not (holding ?b))))
)
