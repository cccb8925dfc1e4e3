; A rule of the stream file derives (goal-pose ?b ?p) from a sampled pose inside a target
; region; the reach test is declared on goal poses only, so it needs the rule's fact.
(define (domain rule)
  (:requirements :strips :typing)
  (:types block pose region)
  (:predicates
    (movable ?b - block)
    (region ?r - region)
    (target ?r - region)
    (pose ?b - block ?p - pose)
    (contained ?b - block ?p - pose ?r - region)
    (goal-pose ?b - block ?p - pose)
    (reachable ?p - pose)
    (at ?b - block ?p - pose)
    (in ?b - block ?r - region)
    (holding ?b - block)
    (hand-empty))

  (:action pick
    :parameters (?b - block ?p - pose ?r - region)
    :precondition (and (at ?b ?p) (in ?b ?r) (hand-empty))
    :effect (and (holding ?b) (not (at ?b ?p)) (not (in ?b ?r)) (not (hand-empty))))

  (:action place
    :parameters (?b - block ?p - pose ?r - region)
    :precondition (and (holding ?b) (contained ?b ?p ?r) (reachable ?p))
    :effect (and (at ?b ?p) (in ?b ?r) (hand-empty) (not (holding ?b))))
)
