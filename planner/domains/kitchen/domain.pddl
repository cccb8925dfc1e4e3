; The PR2 kitchen of Bradley & Roy (after eTAMP): blocks start on the table, must be cleaned at
; the sink and then cooked on the stove. One arm; the base and arm move together between
; configurations that inverse kinematics produces.
(define (domain kitchen)
  (:requirements :strips :negative-preconditions :equality)
  (:predicates
    ; static facts: the scene and what streams certify
    (block ?b)
    (platform ?r)
    (sink ?r)
    (stove ?r)
    (pose ?b ?p)
    (grasp ?b ?g)
    (conf ?q)
    (traj ?t)
    (supported ?b ?p ?r)
    (kin ?b ?p ?g ?q)
    (motion ?q1 ?t ?q2)
    ; fluents
    (at-pose ?b ?p)
    (on ?b ?r)
    (holding ?b ?g)
    (hand-empty)
    (at-conf ?q)
    (can-move)
    (cleaned ?b)
    (cooked ?b))

  ; Base and arm travel along a planned trajectory; two moves in a row are never needed.
  (:action move
    :parameters (?q1 ?q2 ?t)
    :precondition (and (at-conf ?q1) (motion ?q1 ?t ?q2) (can-move) (not (= ?q1 ?q2)))
    :effect (and (at-conf ?q2) (not (at-conf ?q1)) (not (can-move))))

  (:action pick
    :parameters (?b ?p ?r ?g ?q)
    :precondition (and (kin ?b ?p ?g ?q) (supported ?b ?p ?r) (at-pose ?b ?p) (on ?b ?r)
                       (hand-empty) (at-conf ?q))
    :effect (and (holding ?b ?g) (can-move)
                 (not (at-pose ?b ?p)) (not (on ?b ?r)) (not (hand-empty))))

  ; Placing on the stove is cooking (below).
  (:action place
    :parameters (?b ?p ?r ?g ?q)
    :precondition (and (not (stove ?r)) (kin ?b ?p ?g ?q) (supported ?b ?p ?r) (holding ?b ?g) (at-conf ?q))
    :effect (and (at-pose ?b ?p) (on ?b ?r) (hand-empty) (can-move) (not (holding ?b ?g))))

  (:action clean
    :parameters (?b ?r)
    :precondition (and (on ?b ?r) (sink ?r))
    :effect (cleaned ?b))

  ; Cooking puts the cleaned block down on the stove and cooks it there. Placing and cooking
  ; are one action so that plans differing only in when a block on the stove gets cooked do not
  ; flood the top-k planner (they all have the same stream plan); see docs/abstract.md.
  (:action cook
    :parameters (?b ?p ?r ?g ?q)
    :precondition (and (stove ?r) (cleaned ?b) (kin ?b ?p ?g ?q) (supported ?b ?p ?r)
                       (holding ?b ?g) (at-conf ?q))
    :effect (and (cooked ?b) (at-pose ?b ?p) (on ?b ?r) (hand-empty) (can-move)
                 (not (holding ?b ?g)) (not (cleaned ?b))))
)
