"""Whether the robot touches the object it pushes, along a trajectory.

Under the paper's cost (Eq. 2) the arm's controls reach the cost only through contact with the
objects, so an MPC plan whose nominal trajectory never touches the pushed object gives iLQR no
gradient to improve it: this is what ``experiments/svr_explain.py`` checks per optimisation.
Shapes: S states, ns a state row.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from dopt.state import INTEGRATION
from dopt.tasks.push.task_model import TaskModel
from dopt.validation import float_array


def robot_contact(task: TaskModel, target: str | None = None
                  ) -> Callable[[np.ndarray], np.ndarray]:
    """A function (S, ns) states -> (S,) bool: whether any robot geom is in contact (MuJoCo's
    collision detection, within the geoms' margins) with ``target`` (a body or flex name;
    default ``task.pushed_object``) in each state."""
    m = task.model
    name = target or task.pushed_object
    robot = {m.body(b).id for b in task.robot_bodies}
    flex = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_FLEX, name)
    body = -1 if flex >= 0 else m.body(name).id
    ns = mujoco.mj_stateSize(m, INTEGRATION)
    d = mujoco.MjData(m)

    def touches(c) -> bool:
        geoms = [g for g in (c.geom[0], c.geom[1]) if g >= 0]
        if not any(m.geom_bodyid[g] in robot for g in geoms):
            return False
        if flex >= 0:
            return flex in (c.flex[0], c.flex[1])
        return any(m.geom_bodyid[g] == body for g in geoms)

    def contact(states) -> np.ndarray:
        X = float_array(states, "states", (None, ns))
        out = np.zeros(len(X), dtype=bool)
        for i, x in enumerate(X):
            mujoco.mj_setState(m, d, x, INTEGRATION)
            mujoco.mj_kinematics(m, d)
            mujoco.mj_comPos(m, d)
            mujoco.mj_collision(m, d)
            out[i] = any(touches(d.contact[j]) for j in range(d.ncon))
        return out

    return contact
