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

    def step(self, state: np.ndarray, particle: int, displacement: np.ndarray) -> np.ndarray:
        """Execute one action from state: (ns,) -> (ns,)."""

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
        if self.lift < 0 or self.tolerance <= 0 or min(self.per_particle, self.max_actions) < 1:
            raise ValueError(f"need lift >= 0, tolerance > 0, max_actions >= 1, got {self}")


@dataclass(frozen=True)
class ScriptedResult:
    """particles (H,), displacements (H, 3) of the actions taken; cost of the final state;
    final_state (ns,)."""

    particles: np.ndarray
    displacements: np.ndarray
    cost: float
    final_state: np.ndarray


def scripted(task: ScriptedTask, keys, config: ScriptedConfig = ScriptedConfig()
             ) -> ScriptedResult:
    """Run the scripted policy over the key particles ``keys`` (K,), in the given order.

    A key particle within ``tolerance`` of its goal (in xy) is left alone; any other is carried
    towards (goal + lift) and released, in several actions if the bound clips the displacement
    (at most ``per_particle`` per key particle and ``max_actions`` in all). Where it lands is
    not corrected.
    """
    bound = np.asarray(task.bound, dtype=float)
    lift = np.array([0.0, 0.0, config.lift])
    state = np.asarray(task.start_state, dtype=float)
    particles, disps = [], []
    for k in np.asarray(keys, dtype=int).reshape(-1):
        for _ in range(config.per_particle):
            if len(particles) >= config.max_actions:
                break
            p = task.positions(state)[k]
            target = task.goal[k] + lift
            if np.linalg.norm(target[:2] - p[:2]) < config.tolerance:
                break
            d = np.clip(target - p, -bound, bound)
            state = task.step(state, int(k), d)
            particles.append(int(k))
            disps.append(d)
            log.debug("scripted: particle %d moved by %s", k, np.round(d, 4))
            if np.array_equal(d, target - p):    # placed above its goal: next particle
                break
    cost = float(task.cost(state))
    return ScriptedResult(np.array(particles, dtype=np.int64),
                          np.array(disps, dtype=float).reshape(-1, 3), cost, state)
