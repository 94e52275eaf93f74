"""Re-execute a recorded pick-and-place plan and keep its frames, for pictures and GIFs.

``replay(scene, start_state, actions)`` steps a ``DeformableScene`` with plain ``mj_step`` through
a trial's recorded actions (the picker's control rows, ``CONTROL_SPEC``) and returns a ``Replay``:
at most ``max_frames`` evenly spaced states with their step, stage and action. Rendering the
frames is ``dopt.render``'s (which knows no task); ``planners.pick_place.experiments.pictures``
composes the GIF. Shapes: F frames, ns state row, H actions per stage.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from dopt.state import check_states
from dopt.tasks.pick.picker import CONTROL_SPEC
from dopt.tasks.pick.scene import DeformableScene
from dopt.validation import check_int


@dataclass(frozen=True)
class Replay:
    """Recorded frames of an executed plan: states (F, ns) every ``every`` simulation steps
    (the start and the end included), and per frame its simulation step, stage and action
    (indices into the plan; the start frame is stage 0, action 0)."""

    states: np.ndarray
    step: np.ndarray
    stage: np.ndarray
    action: np.ndarray
    every: int


def replay(scene, start_state: np.ndarray, actions: Sequence[dict],
           max_frames: int = 120) -> Replay:
    """Re-execute a pick-and-place plan with plain ``mj_step`` and keep at most
    ``max_frames`` evenly spaced states.

    Args:
        scene: a ``DeformableScene`` (``model``, ``scene.layout.spec``,
            ``picker``).
        start_state: (ns,) where the plan starts.
        actions: per stage {"particles": (H,), "displacements": (H, 3)} (a trial's recorded
            ``actions``), executed in order without resetting between stages.
        max_frames: most frames kept (>= 2).
    """
    if not isinstance(scene, DeformableScene):
        raise TypeError(f"scene must be a DeformableScene, got {type(scene).__name__}")
    max_frames = check_int(max_frames, "max_frames", 2)
    m, spec = scene.model, scene.scene.layout.spec
    start_state = check_states(m, start_state, spec, batched=False, name="start_state")
    if isinstance(actions, (str, Mapping)) or not isinstance(actions, Sequence):
        raise TypeError(f"actions must be a sequence of per-stage dicts, got {actions!r}")
    rows, ends = [], []
    for k, a in enumerate(actions):
        if not isinstance(a, Mapping) or not {"particles", "displacements"} <= set(a):
            raise ValueError(f"actions[{k}] must be a dict with 'particles' (H,) and "
                             f"'displacements' (H, 3), got {a!r}")
        if not np.size(a["particles"]):                  # a stage that took no action
            rows.append(np.empty((0, scene.picker.ncontrol)))
            ends.append(np.zeros(0, dtype=int))
            continue
        plan = scene.picker.schedule(np.asarray(a["particles"])[None],
                                     np.asarray(a["displacements"])[None])
        rows.append(plan.controls[0])                    # (T, nc): the picker's own steps
        ends.append(np.cumsum(plan.steps[0]))            # (H,) where each action ends
    total = sum(len(r) for r in rows)
    every = max(1, int(np.ceil(total / (max_frames - 1))))
    data = mujoco.MjData(m)
    mujoco.mj_setState(m, data, start_state, spec)
    size = mujoco.mj_stateSize(m, spec)
    states, info = [], []

    def keep(step, stage, action):
        x = np.empty(size)
        mujoco.mj_getState(m, data, x, spec)
        states.append(x)
        info.append((step, stage, action))

    keep(0, 0, 0)
    step = 0
    for k, U in enumerate(rows):
        for t, row in enumerate(U):
            mujoco.mj_setState(m, data, row, CONTROL_SPEC)
            mujoco.mj_step(m, data)
            step += 1
            if step % every == 0 or step == total:
                keep(step, k, int(np.searchsorted(ends[k], t, side="right")))
    info = np.array(info, dtype=int).reshape(-1, 3)
    return Replay(np.array(states), info[:, 0], info[:, 1], info[:, 2], every)
