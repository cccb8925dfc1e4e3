; A PDDLStream-style domain, as PDDLStream's examples write them: names in CamelCase, the static
; facts (Block, Region, Conf, Kin, ...) declared only by their use, a derived predicate missing
; from :predicates, and the cost function declared by the stream file.
(define (domain tiny-pddlstream)
  (:requirements :strips :equality)
  (:predicates (AtPose ?b ?p) (AtConf ?q) (Holding ?b ?g) (HandEmpty) (CanMove))
  (:derived (InRegion ?b ?r)
    (exists (?p) (and (Contained ?b ?p ?r) (AtPose ?b ?p))))
  (:action move
    :parameters (?q1 ?q2)
    :precondition (and (Conf ?q1) (Conf ?q2) (AtConf ?q1) (CanMove))
    :effect (and (AtConf ?q2) (not (AtConf ?q1)) (not (CanMove))
                 (increase (total-cost) (Distance ?q1 ?q2))))
  (:action pick
    :parameters (?b ?p ?g ?q)
    :precondition (and (Kin ?b ?p ?g ?q) (AtPose ?b ?p) (HandEmpty) (AtConf ?q))
    :effect (and (Holding ?b ?g) (CanMove) (not (AtPose ?b ?p)) (not (HandEmpty))
                 (increase (total-cost) 1)))
  (:action place
    :parameters (?b ?p ?g ?q)
    :precondition (and (Kin ?b ?p ?g ?q) (Holding ?b ?g) (AtConf ?q) (Reachable ?q)
                       (not (Blocked ?q)))
    :effect (and (AtPose ?b ?p) (HandEmpty) (CanMove) (not (Holding ?b ?g))
                 (increase (total-cost) 1)))
)
