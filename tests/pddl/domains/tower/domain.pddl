; Stacking: (above ?x ?y) is derived recursively, with a disjunction in its body. A block goes
; on another at a sampled offset that a test finds stable.
(define (domain tower)
  (:requirements :strips :typing :negative-preconditions :equality :derived-predicates
                 :disjunctive-preconditions :existential-preconditions)
  (:types block offset)
  (:predicates
    (block ?b - block)
    (offset ?b - block ?c - block ?o - offset)
    (stable ?b - block ?c - block ?o - offset)
    (on-floor ?b - block)
    (on ?b - block ?c - block)
    (clear ?b - block)
    (holding ?b - block)
    (hand-empty)
    (above ?x - block ?y - block))

  (:derived (above ?x - block ?y - block)
    (or (on ?x ?y)
        (exists (?z - block) (and (on ?x ?z) (above ?z ?y)))))

  (:action pick
    :parameters (?b - block)
    :precondition (and (on-floor ?b) (clear ?b) (hand-empty))
    :effect (and (holding ?b) (not (on-floor ?b)) (not (clear ?b)) (not (hand-empty))))

  (:action stack
    :parameters (?b - block ?c - block ?o - offset)
    :precondition (and (holding ?b) (clear ?c) (stable ?b ?c ?o) (not (= ?b ?c)))
    :effect (and (on ?b ?c) (clear ?b) (hand-empty) (not (holding ?b)) (not (clear ?c))))
)
