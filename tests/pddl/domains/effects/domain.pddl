; A tray carries every block loaded on it: a universal, conditional effect. A block arrives
; only if its slot on the tray is stable for the trip (a test stream's fact inside the (when
; ...) condition), so the stream plan must test the slots of the blocks the plan carries.
(define (domain effects)
  (:requirements :strips :typing :negative-preconditions :conditional-effects
                 :universal-preconditions)
  (:types block slot place route)
  (:predicates
    (block ?b - block)
    (place ?l - place)
    (slot ?s - slot)
    (stable ?s - slot ?l - place)
    (route ?from - place ?to - place ?w - route)
    (in ?b - block ?l - place)
    (loaded ?b - block ?s - slot)
    (occupied ?s - slot)
    (tray-at ?l - place))

  (:action load
    :parameters (?b - block ?s - slot ?l - place)
    :precondition (and (in ?b ?l) (tray-at ?l) (slot ?s) (not (occupied ?s)))
    :effect (and (loaded ?b ?s) (occupied ?s) (not (in ?b ?l))))

  (:action unload
    :parameters (?b - block ?s - slot ?l - place)
    :precondition (and (loaded ?b ?s) (tray-at ?l))
    :effect (and (in ?b ?l) (not (loaded ?b ?s)) (not (occupied ?s))))

  (:action carry
    :parameters (?from - place ?to - place ?w - route)
    :precondition (and (tray-at ?from) (route ?from ?to ?w))
    :effect (and (tray-at ?to) (not (tray-at ?from))
                 (forall (?b - block ?s - slot)
                   (when (and (loaded ?b ?s) (not (stable ?s ?to)))
                     (and (not (loaded ?b ?s)) (not (occupied ?s)))))))
)
