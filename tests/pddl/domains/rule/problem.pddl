(define (problem rule-1)
  (:domain rule)
  (:objects a - block x0-a - pose start goal - region)
  (:init
    (movable a) (region start) (region goal) (target goal)
    (pose a x0-a) (contained a x0-a start) (at a x0-a) (in a start) (hand-empty))
  (:goal (in a goal)))
