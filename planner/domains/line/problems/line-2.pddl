; Two blocks start in region start and must both end in region goal.
(define (problem line-2)
  (:domain line)
  (:objects a b - block start goal - region pa pb - pose)
  (:init
    (movable a) (movable b) (region start) (region goal) (hand-empty)
    (valid a pa) (contained a pa start) (at a pa) (in a start)
    (valid b pb) (contained b pb start) (at b pb) (in b start))
  (:goal (and (in a goal) (in b goal))))
