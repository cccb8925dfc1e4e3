; A robot drives between stations along roads whose lengths are given in the problem's
; initial state ((= (road ?a ?b) 2.5)); driving costs the road's length, picking costs 1.
; The sampled grasp makes it TAMP: the robot must reach the block's station.
(define (domain costs)
  (:requirements :strips :typing :action-costs)
  (:types station block grasp)
  (:predicates
    (block ?b - block)
    (grip ?b - block ?g - grasp)
    (connected ?a - station ?b - station)
    (robot-at ?s - station)
    (at ?b - block ?s - station)
    (holding ?b - block ?g - grasp)
    (hand-empty))
  (:functions (total-cost) - number (road ?a - station ?b - station) - number)

  (:action drive
    :parameters (?a - station ?b - station)
    :precondition (and (robot-at ?a) (connected ?a ?b))
    :effect (and (robot-at ?b) (not (robot-at ?a)) (increase (total-cost) (road ?a ?b))))

  (:action pick
    :parameters (?b - block ?s - station ?g - grasp)
    :precondition (and (robot-at ?s) (at ?b ?s) (grip ?b ?g) (hand-empty))
    :effect (and (holding ?b ?g) (not (at ?b ?s)) (not (hand-empty))
                 (increase (total-cost) 1)))

  (:action place
    :parameters (?b - block ?s - station ?g - grasp)
    :precondition (and (robot-at ?s) (holding ?b ?g))
    :effect (and (at ?b ?s) (hand-empty) (not (holding ?b ?g)) (increase (total-cost) 1)))
)
