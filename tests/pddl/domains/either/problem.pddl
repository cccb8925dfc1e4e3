; The vice is marked movable (so poses get sampled for it) but is a fixture: tests that ask
; for it in the goal region find the goal unreachable.
(define (problem either-3)
  (:domain either)
  (:objects cube - block hammer - tool vice - fixture
            x0-cube x0-hammer x0-vice - pose start goal - region)
  (:init
    (region start) (region goal) (movable cube) (movable hammer) (movable vice)
    (pose cube x0-cube) (pose hammer x0-hammer) (pose vice x0-vice)
    (contained cube x0-cube start) (contained hammer x0-hammer start)
    (contained vice x0-vice start)
    (at cube x0-cube) (at hammer x0-hammer) (at vice x0-vice)
    (in cube start) (in hammer start) (in vice start) (hand-empty))
  (:goal (and (in cube goal) (in hammer goal))))
