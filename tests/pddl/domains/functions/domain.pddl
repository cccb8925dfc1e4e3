; The robot inspects two blocks from sampled configurations; moving costs the distance
; between the configurations, a (:function ...) of the stream file computed by Python once
; both are bound (before that, its declared lower bound).
(define (domain functions)
  (:requirements :strips :typing :action-costs :negative-preconditions :equality)
  (:types block conf)
  (:predicates
    (block ?b - block)
    (conf ?q - conf)
    (kin ?b - block ?q - conf)
    (at-conf ?q - conf)
    (seen ?b - block))
  (:functions (total-cost) - number (dist ?q1 - conf ?q2 - conf) - number)

  (:action move
    :parameters (?q1 - conf ?q2 - conf)
    :precondition (and (at-conf ?q1) (conf ?q2) (not (= ?q1 ?q2)))
    :effect (and (at-conf ?q2) (not (at-conf ?q1)) (increase (total-cost) (dist ?q1 ?q2))))

  (:action inspect
    :parameters (?b - block ?q - conf)
    :precondition (and (at-conf ?q) (kin ?b ?q))
    :effect (and (seen ?b) (increase (total-cost) 1)))
)
