; A blocksworld with streams, after PDDLStream's discrete examples as its papers describe them:
; one arm moves blocks between table slots and the tops of other blocks. What the arm may do is
; not in the domain but in the streams: whether a block may stand on another or in a slot
; (tests over the blocks' widths and fragility) and the carry itself, a fluent stream that
; reads where the stacks stand, may fail for a heavy block held far from the arm's base, and
; gives the trajectory whose seconds are the plan's execution time. Written in PDDLStream's
; style: Block, Slot, Stackable and Carry are declared only by their use.
(define (domain blocks-streams)
  (:requirements :strips :equality)
  (:predicates (On ?b ?x) (Clear ?x))

  (:action move
    :parameters (?b ?x ?y ?t)
    :precondition (and (Block ?b) (On ?b ?x) (Clear ?b) (Clear ?y) (not (= ?b ?y)) (not (= ?x ?y))
                       (Stackable ?b ?y) (Carry ?b ?x ?y ?t))
    :effect (and (On ?b ?y) (Clear ?x) (not (On ?b ?x)) (not (Clear ?y))
                 (increase (total-cost) 1)))
)
