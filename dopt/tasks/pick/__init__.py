"""The pick-and-place wing of ``dopt.tasks``: a one-point picker moves a rope or a cloth.

    picker.py       the picker (slide joints, grasp equalities), actions <-> control rows
    scene.py        floor_scene_xml, DeformableScene (particles <-> state rows), PickPlaceTask
                    (Eq. 2 of a population of action sequences in one rollout call),
                    mean_distance, end_to_end, matching_distance (the paper's metrics)
    cloth_scene.py  ClothSceneConfig, make_cloth; rope_scene.py: RopeSceneConfig, make_rope
    fold_goals.py   cloth goals folded on the MuJoCo sheet by a line grasp (fold_goal, folds)
    settle.py       sampled rollouts action by action, each settle ended once the object is at
                    rest (RestTest, rollout_until_rest; PickPlaceTask(rest=...))
    replay.py       a recorded plan re-executed with mj_step, its frames kept (replay, Replay)
    panda_gripper.py  a Panda with a two-finger hand executes picker plans (the arm is
                    the neutral dopt.tasks.panda, shared with the push wing)
    constraints.py  the action constraint C(a_t): the picker's workspace box
    drag.py         short drags of virtual pick points attached to the mesh (the key-particle
                    authors' action encoding, N free of the physics mesh)
    pinned.py       a scene with particles welded to the world, relaxed to equilibrium
                    (PinnedScene: the physics references' pins and clamps)

The scene builders are registered by name in ``dopt.tasks.PICK_SCENES``.
"""
