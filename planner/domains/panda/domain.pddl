; A Franka Panda at a table: blocks go from a cluttered table into a tray (or onto a shelf) with
; little room. The arm is fixed; it moves between the configurations inverse kinematics produces.
; A block whose grasps a tall obstacle blocks is picked only once that obstacle has been moved
; ((obstructs ?o ?b) comes from the scene: the seeded spawn stands ?o next to ?b). A start pose
; is not (supported ...): a block is never put back where it started (an obstacle put back
; would stand in the way again).
(define (domain panda)
  (:requirements :strips :negative-preconditions :equality)
  (:predicates
    ; static facts: the scene and what streams certify
    (block ?b)
    (region ?r)
    (placeable ?b ?r)
    (obstructs ?o ?b)
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
    (obstructed ?b)
    (holding ?b ?g)
    (hand-empty)
    (at-conf ?q)
    (can-move))

  ; The arm travels along a planned trajectory; two moves in a row are never needed.
  (:action move
    :parameters (?q1 ?q2 ?t)
    :precondition (and (at-conf ?q1) (motion ?q1 ?t ?q2) (can-move) (not (= ?q1 ?q2)))
    :effect (and (at-conf ?q2) (not (at-conf ?q1)) (not (can-move))))

  (:action pick
    :parameters (?b ?p ?r ?g ?q)
    :precondition (and (not (obstructed ?b)) (kin ?b ?p ?g ?q) (at-pose ?b ?p) (on ?b ?r)
                       (hand-empty) (at-conf ?q))
    :effect (and (holding ?b ?g) (can-move)
                 (not (at-pose ?b ?p)) (not (on ?b ?r)) (not (hand-empty))))

  ; Picking the obstacle ?o that stands in the way of ?b's grasps frees ?b.
  (:action pick-obstacle
    :parameters (?o ?b ?p ?r ?g ?q)
    :precondition (and (obstructs ?o ?b) (not (obstructed ?o)) (kin ?o ?p ?g ?q)
                       (at-pose ?o ?p) (on ?o ?r) (hand-empty) (at-conf ?q))
    :effect (and (holding ?o ?g) (can-move) (not (obstructed ?b))
                 (not (at-pose ?o ?p)) (not (on ?o ?r)) (not (hand-empty))))

  (:action place
    :parameters (?b ?p ?r ?g ?q)
    :precondition (and (placeable ?b ?r) (kin ?b ?p ?g ?q) (supported ?b ?p ?r) (holding ?b ?g)
                       (at-conf ?q))
    :effect (and (at-pose ?b ?p) (on ?b ?r) (hand-empty) (can-move) (not (holding ?b ?g))))
)
