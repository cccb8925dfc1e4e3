; Three blocks on the floor; a above c and b above c with a clear: only the tower c-b-a, where
; a is above c through b (the recursion of the derived predicate).
(define (problem tower-3)
  (:domain tower)
  (:objects a b c - block)
  (:init
    (block a) (block b) (block c)
    (on-floor a) (on-floor b) (on-floor c) (clear a) (clear b) (clear c) (hand-empty))
  (:goal (and (above a c) (above b c) (clear a))))
