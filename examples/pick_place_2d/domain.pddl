; A 2-D continuous pick-and-place, after PDDLStream's continuous_tamp example as its papers
; describe it: a gripper over a 1-D table of blocks moves them into regions. Written the way
; PDDLStream's examples write their domains (CamelCase names, static facts such as Block,
; Conf, Kin and CFree declared only by their use in the streams and the actions, a derived
; predicate missing from :predicates), so that it loads only through PDDLStream's leniency:
; `tamp check examples/pick_place_2d` lists what is inferred.
(define (domain pick-place-2d)
  (:requirements :strips :equality :universal-preconditions :derived-predicates)
  (:predicates
    ; fluents
    (AtPose ?b ?p) (AtConf ?q) (Holding ?b ?g) (HandEmpty) (CanMove))
  (:functions (Dist ?q1 ?q2))

  ; The gripper follows a trajectory the motion planner made between two configurations.
  (:action move
    :parameters (?q1 ?t ?q2)
    :precondition (and (Motion ?q1 ?t ?q2) (AtConf ?q1) (CanMove))
    :effect (and (AtConf ?q2) (not (AtConf ?q1)) (not (CanMove))
                 (increase (total-cost) (Dist ?q1 ?q2))))

  (:action pick
    :parameters (?b ?p ?g ?q)
    :precondition (and (Kin ?b ?p ?g ?q) (AtPose ?b ?p) (HandEmpty) (AtConf ?q))
    :effect (and (Holding ?b ?g) (CanMove)
                 (not (AtPose ?b ?p)) (not (HandEmpty))
                 (increase (total-cost) 1)))

  ; A block goes down only where it is clear of every block on the table.
  (:action place
    :parameters (?b ?p ?g ?q)
    :precondition (and (Kin ?b ?p ?g ?q) (Holding ?b ?g) (AtConf ?q)
                       (forall (?b2 ?p2) (imply (AtPose ?b2 ?p2) (CFree ?b ?p ?b2 ?p2))))
    :effect (and (AtPose ?b ?p) (HandEmpty) (CanMove)
                 (not (Holding ?b ?g))
                 (increase (total-cost) 1)))

  (:derived (In ?b ?r)
    (exists (?p) (and (Contained ?b ?p ?r) (AtPose ?b ?p))))
)
