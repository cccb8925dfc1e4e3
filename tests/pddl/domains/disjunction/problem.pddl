; The fragile egg must go into a padded region: the left bin (only the left arm reaches it)
; or the right bin (only the right arm does); the plain box does not count. Which arm picks
; and places the egg is the planner's choice of disjunct, and decides the reach tests.
(define (problem disjunction-1)
  (:domain disjunction)
  (:objects egg - block x0-egg - pose start left-bin right-bin box - region)
  (:init
    (movable egg) (region start) (region left-bin) (region right-bin) (region box)
    (fragile egg) (padded left-bin) (padded right-bin)
    (pose egg x0-egg) (contained egg x0-egg start) (at egg x0-egg) (in egg start)
    (hand-empty))
  (:goal (or (in egg left-bin) (in egg right-bin) (in egg box))))
