"""The pushing wing of ``dopt.tasks``: the Franka Panda pushes rigid cylinders and soft bodies.

    task_model.py  TaskModel (one built task: model, initial state, what the cost looks at),
                   PushTaskSpec (a task by name: T, dt, Y, slowdown, nv and its builder),
                   planar_dofs, require_generator
    clutter.py     CLUTTER, build_clutter; soft.py: SOFT, SOFT_RIGID, build_soft,
                   build_soft_rigid
    authors.py     the authors' own problems: build_clutter_authors (their scene files),
                   build_soft_authors, build_soft_rigid_authors
    warm_start.py  the set-up motion and the first push plan (its last control keeps pushing)
    contact.py     robot_contact: whether the robot touches the pushed object, per state
    costs.py       push_cost (Eq. 2-3), PushWeights, goal_distance (imports torch)

The arm is the neutral ``dopt.tasks.panda`` (shared with the pick wing's executor: the
wings never import each other). The specs are registered by CLI name in
``dopt.tasks.PUSH_TASKS``.
"""
