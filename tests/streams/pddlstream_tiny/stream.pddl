(define (stream tiny-pddlstream)
  ; A pose in the region clear of the blocks placed there (a fluent stream: it reads AtPose).
  (:stream sample-pose
    :inputs (?b ?r)
    :domain (and (Block ?b) (Region ?r))
    :fluents (AtPose)
    :outputs (?p)
    :certified (and (Pose ?b ?p) (Contained ?b ?p ?r)))
  ; The grasps of a block: a finite list.
  (:stream sample-grasp
    :inputs (?b)
    :domain (Block ?b)
    :outputs (?g)
    :certified (Grasp ?b ?g))
  ; The one gripper position that holds the block at ?p with grasp ?g.
  (:stream inverse-kinematics
    :inputs (?b ?p ?g)
    :domain (and (Pose ?b ?p) (Grasp ?b ?g))
    :outputs (?q)
    :certified (and (Conf ?q) (Kin ?b ?p ?g ?q)))
  ; Whether the arm reaches ?q.
  (:stream test-reachable
    :inputs (?q)
    :domain (Conf ?q)
    :certified (Reachable ?q))
  ; A lazily evaluated test: a gripper position inside the obstacle is blocked.
  (:predicate (Blocked ?q) (Conf ?q))
  ; How far the gripper travels.
  (:function (Distance ?q1 ?q2) (and (Conf ?q1) (Conf ?q2)))
)
