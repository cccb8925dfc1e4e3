; As derived-2. Two blocks 1 wide into a goal region 2.6 wide: about one pair of sampled poses in seven
; leaves room for both.
(define (problem safe-2)
  (:domain safe)
  (:objects a b - block x0-a x0-b - pose start goal - region)
  (:init
    (movable a) (movable b) (region start) (region goal)
    (pose a x0-a) (pose b x0-b) (contained a x0-a start) (contained b x0-b start)
    (at a x0-a) (at b x0-b) (in a start) (in b start) (hand-empty))
  (:goal (and (in a goal) (in b goal))))
