; A robot arm over a grid of cells picks blocks up and puts them down, after PDDLStream's
; discrete TAMP example as its documentation describes it. Written the way PDDLStream's examples
; write their domains: CamelCase names, the static facts (Block, Pose, Conf, Kin, Motion, CFree,
; Target) declared only by their use, and a constant (home, the arm's resting configuration,
; whose value the scene gives through PDDLStream's constant_map).
(define (domain grid-tamp)
  (:requirements :strips :equality :universal-preconditions :disjunctive-preconditions)
  (:constants home)
  (:predicates (AtConf ?q) (AtPose ?b ?p) (Holding ?b) (HandEmpty) (CanMove))

  ; The gripper travels along a path of cells the motion stream made.
  (:action move
    :parameters (?q1 ?t ?q2)
    :precondition (and (Motion ?q1 ?t ?q2) (AtConf ?q1) (CanMove))
    :effect (and (AtConf ?q2) (not (AtConf ?q1)) (not (CanMove)) (increase (total-cost) 1)))

  (:action pick
    :parameters (?b ?p ?q)
    :precondition (and (Block ?b) (Kin ?q ?p) (AtConf ?q) (AtPose ?b ?p) (HandEmpty))
    :effect (and (Holding ?b) (CanMove) (not (AtPose ?b ?p)) (not (HandEmpty))
                 (increase (total-cost) 1)))

  ; A block goes down only on a cell no other block stands on.
  (:action place
    :parameters (?b ?p ?q)
    :precondition (and (Block ?b) (Kin ?q ?p) (AtConf ?q) (Holding ?b)
                       (forall (?b2 ?p2) (imply (AtPose ?b2 ?p2) (CFree ?p ?p2))))
    :effect (and (AtPose ?b ?p) (HandEmpty) (CanMove) (not (Holding ?b))
                 (increase (total-cost) 1)))
)
