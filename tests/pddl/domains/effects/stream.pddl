(define (stream effects)
  ; A slot on the tray for a block (a position along the tray, 0 to 1).
  (:stream sample-slot
    :inputs (?b)
    :domain (block ?b)
    :outputs (?s - slot)
    :certified (slot ?s))

  ; A block in this slot stays on the tray on the way to ?l.
  (:stream test-stable
    :inputs (?s ?l)
    :domain (and (slot ?s) (place ?l))
    :certified (stable ?s ?l))

  ; A route for the tray.
  (:stream plan-route
    :inputs (?from ?to)
    :domain (and (place ?from) (place ?to))
    :outputs (?w - route)
    :certified (route ?from ?to ?w))
)
