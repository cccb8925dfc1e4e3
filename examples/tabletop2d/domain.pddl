; A 2-D tabletop: a gripper over a table picks blocks from one region and places them in others.
; Placing needs a collision test against the blocks already in the region (test-cfree), and the
; gripper reaches only so far (inverse-kinematics fails beyond its reach).
(define (domain tabletop2d)
  (:requirements :strips :negative-preconditions)
  (:predicates
    (block ?b) (region ?r)
    (pose ?b ?p) (grasp ?b ?g) (conf ?q) (path ?t)
    (contained ?b ?p ?r)      ; pose ?p of block ?b lies inside region ?r
    (cfree ?b ?p ?r)          ; ... and clear of the blocks in ?r when it is placed there
    (kin ?b ?p ?g ?q)         ; the gripper at ?q holds ?b at ?p with grasp ?g
    (motion ?q1 ?t ?q2)       ; path ?t takes the gripper from ?q1 to ?q2
    (at ?b ?p) (in ?b ?r) (holding ?b ?g) (hand-empty) (at-conf ?q) (can-move))

  (:action move
    :parameters (?q1 ?q2 ?t)
    :precondition (and (at-conf ?q1) (motion ?q1 ?t ?q2) (can-move))
    :effect (and (at-conf ?q2) (not (at-conf ?q1)) (not (can-move))))

  (:action pick
    :parameters (?b ?p ?r ?g ?q)
    :precondition (and (at ?b ?p) (in ?b ?r) (kin ?b ?p ?g ?q) (hand-empty) (at-conf ?q))
    :effect (and (holding ?b ?g) (can-move)
                 (not (at ?b ?p)) (not (in ?b ?r)) (not (hand-empty))))

  (:action place
    :parameters (?b ?p ?r ?g ?q)
    :precondition (and (holding ?b ?g) (contained ?b ?p ?r) (cfree ?b ?p ?r) (kin ?b ?p ?g ?q)
                       (at-conf ?q))
    :effect (and (at ?b ?p) (in ?b ?r) (hand-empty) (can-move) (not (holding ?b ?g))))
)
