(define (problem quantifiers-2)
  (:domain quantifiers)
  (:objects a b - block x0-a x0-b - pose start goal - region)
  (:init
    (movable a) (movable b) (region start) (region goal) (target goal)
    (pose a x0-a) (pose b x0-b) (contained a x0-a start) (contained b x0-b start)
    (at a x0-a) (at b x0-b) (in a start) (in b start) (hand-empty))
  (:goal (forall (?b - block) (exists (?r - region) (and (target ?r) (in ?b ?r))))))
