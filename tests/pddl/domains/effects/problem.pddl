; Two blocks ride the tray from the kitchen to the table: each block's slot must be tested
; stable, or the carry drops it (the conditional effect).
(define (problem effects-2)
  (:domain effects)
  (:objects a b - block kitchen table - place)
  (:init (block a) (block b) (place kitchen) (place table)
         (in a kitchen) (in b kitchen) (tray-at kitchen))
  (:goal (and (in a table) (in b table))))
