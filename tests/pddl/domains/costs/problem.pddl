; From the depot to the shelf and back to the depot with the block: the direct road is 9.5,
; the detour through the hall 2.5 + 3.25. The cheapest plan takes the detour both ways.
(define (problem costs-1)
  (:domain costs)
  (:objects depot hall shelf - station box - block)
  (:init
    (block box) (robot-at depot) (at box shelf) (hand-empty)
    (connected depot shelf) (connected shelf depot) (connected depot hall)
    (connected hall depot) (connected hall shelf) (connected shelf hall)
    (= (road depot shelf) 9.5) (= (road shelf depot) 9.5)
    (= (road depot hall) 2.5) (= (road hall depot) 2.5)
    (= (road hall shelf) 3.25) (= (road shelf hall) 3.25))
  (:goal (at box depot))
  (:metric minimize (total-cost)))
