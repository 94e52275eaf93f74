"""The paper's scripted baseline: pick each key particle, move it above its goal, release.

One action at a time: each displacement is computed from the current particle positions (the
bound may need several actions per particle). Knows nothing of ropes or
cloth: it talks to a ``ScriptedTask``.

Shapes: N particles, K key particles, H actions taken.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from dopt.validation import check_config, float_array
from planners._checks import particle_indices, picker_bound

log = logging.getLogger(__name__)


class ScriptedTask(Protocol):
    """What the scripted policy needs from a task."""

    bound: np.ndarray
    """(3,) largest |displacement| per axis (m)."""
    goal: np.ndarray
    """(N, 3) goal positions (m)."""
    start_state: np.ndarray

    def positions(self, state: np.ndarray) -> np.ndarray:
        """(ns,) -> (N, 3) particle positions."""

    def step(self, state: np.ndarray, particle: int, displacement: np.ndarray):
        """Execute one action from state (ns,): an object with ``state`` (ns,), ``unstable``
        (bool) and ``reason`` (str), as ``dopt.tasks.pick.scene.Execution``."""

    def cost(self, states: np.ndarray) -> np.ndarray:
        """(..., ns) -> (...) cost."""


@dataclass(frozen=True)
class ScriptedConfig:
    """Scripted policy settings.

    Attributes:
        lift: height above the goal position the particle is carried to (m).
        tolerance: a key particle closer than this to its goal (in xy) is left alone (m).
        per_particle: cap on the actions per key particle.
        max_actions: cap on the actions of one run.
    """

    lift: float = 0.02
    tolerance: float = 0.01
    per_particle: int = 3
    max_actions: int = 12

    def __post_init__(self):
        check_config(self, positive=("tolerance",),
                     minimum={"lift": 0.0, "per_particle": 1, "max_actions": 1})


@dataclass(frozen=True)
class ScriptedResult:
    """particles (H,), displacements (H, 3) of the actions taken; cost of the final state;
    final_state (ns,); unstable: whether an action's simulation broke a stability bound (the
    policy stops there) and the reason."""

    particles: np.ndarray
    displacements: np.ndarray
    cost: float
    final_state: np.ndarray
    unstable: bool = False
    reason: str = ""


def scripted(task: ScriptedTask, keys, config: ScriptedConfig = ScriptedConfig()
             ) -> ScriptedResult:
    """Run the scripted policy over the key particles ``keys`` (K,), in the given order.

    A key particle within ``tolerance`` of its goal (in xy) is left alone; any other is carried
    towards (goal + lift), its place point clipped into the task's workspace (``constraint``,
    C(a_t), when the task has one), and released, in several actions if the bound clips the
    displacement
    (at most ``per_particle`` per key particle and ``max_actions`` in all). Where it lands is
    not corrected. An action whose simulation goes unstable ends the run, flagged in the result.

    Raises:
        TypeError: keys that are not integers, a config that is not a ScriptedConfig.
        ValueError: empty, negative or out-of-range keys (the task's ``goal`` has N rows), a
            bad bound, a goal that is not a finite (N, 3) array, a non-finite start state.
        RuntimeError: the final state's cost is not finite.
    """
    if not isinstance(config, ScriptedConfig):
        raise TypeError(f"config must be a ScriptedConfig, got {type(config).__name__}")
    bound = picker_bound(task.bound)
    goal = float_array(task.goal, "task.goal", (None, 3))
    keys = particle_indices(keys, "keys", len(goal))
    lift = np.array([0.0, 0.0, config.lift])
    constraint = getattr(task, "constraint", None)
    state = float_array(task.start_state, "task.start_state", ndim=1)
    particles, disps, reason = [], [], ""
    for k in keys:
        if reason:
            break
        for _ in range(config.per_particle):
            if len(particles) >= config.max_actions:
                break
            p = task.positions(state)[k]
            target = goal[k] + lift
            if np.linalg.norm(target[:2] - p[:2]) < config.tolerance:
                break
            d = np.clip(target - p, -bound, bound)
            if constraint is not None:       # C(a_t): the place point inside the workspace
                d = constraint.project(task.positions(state), np.int64(k), d)
            done = task.step(state, int(k), d)
            state = done.state
            particles.append(int(k))
            disps.append(d)
            log.debug("scripted: particle %d moved by %s", k, np.round(d, 4))
            if done.unstable:
                reason = f"action {len(particles) - 1}: {done.reason}"
                log.warning("scripted: the simulation went unstable (%s)", reason)
                break
            if np.array_equal(d, target - p):    # placed above its goal: next particle
                break
    cost = float(task.cost(state))
    if not np.isfinite(cost):
        raise RuntimeError(f"the scripted policy's final state has a non-finite cost ({cost}) "
                           f"after {len(particles)} actions")
    return ScriptedResult(np.array(particles, dtype=np.int64),
                          np.array(disps, dtype=float).reshape(-1, 3), cost, state,
                          bool(reason), reason)
