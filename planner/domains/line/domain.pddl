; A tiny test domain: blocks on a 1-D line are picked and placed into regions. Pure Python
; samplers (no geometry engine), so tests run the whole pipeline in milliseconds.
(define (domain line)
  (:requirements :strips :typing :negative-preconditions)
  (:types block region pose)
  (:predicates
    (movable ?b - block)
    (region ?r - region)
    (valid ?b - block ?p - pose)
    (contained ?b - block ?p - pose ?r - region)
    (reachable ?p - pose)
    (at ?b - block ?p - pose)
    (in ?b - block ?r - region)
    (holding ?b - block)
    (hand-empty))

  (:action pick
    :parameters (?b - block ?p - pose ?r - region)
    :precondition (and (at ?b ?p) (in ?b ?r) (contained ?b ?p ?r) (reachable ?p) (hand-empty))
    :effect (and (holding ?b) (not (at ?b ?p)) (not (in ?b ?r)) (not (hand-empty))))

  (:action place
    :parameters (?b - block ?p - pose ?r - region)
    :precondition (and (holding ?b) (contained ?b ?p ?r) (reachable ?p))
    :effect (and (at ?b ?p) (in ?b ?r) (hand-empty) (not (holding ?b))))
)
