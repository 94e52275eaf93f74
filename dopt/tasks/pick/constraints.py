"""The action constraint C(a_t) of the key-particle paper (Eq. 2: min ||xi_G - xi_T|| s.t.
C(a_t) < 0), for one picker on a rope or cloth.

The paper leaves C to SoftGym: its picker clips every commanded position to a workspace box
(``Picker._apply_picker_boundary``), and with two or more pickers it reverts a step that would
pull two held particles beyond 1.2 times their initial distance. With one picker, as here and
in the paper's experiments, only the box and the per-axis displacement bound act. We define

    C(a) = max over axes of max(low - q, q - high),   q = x_i + d,

the signed distance (m) of the place point q of action a = (i, d) outside the workspace box
[low, high] (negative inside: feasible), and, after simulating the action, the stretch part:
a = infeasible when some flex edge away from the grasp stretched beyond ``max_stretch``
(relative, |l / l0 - 1|; the stability verdict's ``max_strain``). ``max_stretch`` is off by
default: random actions on the default sheet already reach a median strain of 0.41 away from
the grasp (docs/RESULTS.md, physics presets), so a SoftGym-like 0.2 would reject most of them.

Enforcement (docs/DESIGN-NOTES.md): the picker's slide joints are limited to the box
(``PickerConfig.workspace``), so every step of every rollout, sampled by CEM or executed,
keeps the grasped particle inside it, as SoftGym clips; ``project`` gives the displacement
that clipping leaves of an action from a known state (what the scripted policy commands).

Shapes: N particles, (...) any batch of actions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dopt.validation import check_config, float_array

#: top of the workspace (m above the floor): SoftGym's picker_high along its up axis
WORKSPACE_HEIGHT = 0.5


@dataclass(frozen=True)
class ActionConstraint:
    """C(a_t) (see the module docstring).

    Attributes:
        low, high: (3,) corners of the workspace box (m, world frame), low < high per axis.
        max_stretch: largest relative edge elongation away from the grasp a simulated action
            may cause (None: not judged).
    """

    low: tuple[float, float, float]
    high: tuple[float, float, float]
    max_stretch: float | None = None

    def __post_init__(self):
        check_config(self, positive=("max_stretch",))
        low, high = np.asarray(self.low, float), np.asarray(self.high, float)
        if not np.all(low < high):
            raise ValueError(f"ActionConstraint needs low < high on every axis, got low "
                             f"{low.tolist()}, high {high.tolist()}")
        object.__setattr__(self, "low", tuple(low.tolist()))
        object.__setattr__(self, "high", tuple(high.tolist()))

    def contains(self, point) -> bool:
        """Whether a point (3,) lies inside the box (faces included)."""
        p = float_array(point, "point", (3,))
        return bool(np.all(p >= self.low) and np.all(p <= self.high))

    @classmethod
    def table(cls, half_width: float, height: float = WORKSPACE_HEIGHT,
              max_stretch: float | None = None) -> ActionConstraint:
        """A box centred on the origin: |x|, |y| <= half_width, 0 <= z <= height (SoftGym's
        cloth workspace is the sheet's own size on each side of its centre)."""
        w = float(half_width)
        return cls((-w, -w, 0.0), (w, w, float(height)), max_stretch)

    def value(self, positions, particles, displacements) -> np.ndarray:
        """C of actions from known particle positions: (N, 3), (...) ints, (..., 3) metres ->
        (...) metres, < 0 feasible. A None action (particle -1) is feasible (-inf)."""
        q, none = self._place(positions, particles, displacements)
        c = np.max(np.maximum(np.asarray(self.low) - q, q - np.asarray(self.high)), axis=-1)
        return np.where(none, -np.inf, c)

    def feasible(self, positions, particles, displacements) -> np.ndarray:
        """C < 0: (N, 3), (...), (..., 3) -> (...) bool."""
        return self.value(positions, particles, displacements) < 0

    def project(self, positions, particles, displacements) -> np.ndarray:
        """The displacements with each place point clipped into the box (what the picker's
        joint limits leave of them): (N, 3), (...), (..., 3) -> (..., 3)."""
        q, none = self._place(positions, particles, displacements)
        d = np.asarray(displacements, dtype=float) + (np.clip(q, self.low, self.high) - q)
        return np.where(none[..., None], 0.0, d)

    def stretched(self, max_strain) -> np.ndarray:
        """Which simulated actions broke the stretch limit: (...) strains -> (...) bool (all
        False when ``max_stretch`` is None)."""
        s = np.asarray(max_strain, dtype=float)
        return np.zeros(s.shape, bool) if self.max_stretch is None else s > self.max_stretch

    def _place(self, positions, particles, displacements) -> tuple[np.ndarray, np.ndarray]:
        x = float_array(positions, "positions", (None, 3))
        idx = np.asarray(particles)
        if idx.dtype.kind not in "iu":
            raise TypeError(f"particles must be integer indices, got dtype {idx.dtype}")
        d = float_array(displacements, "displacements")
        if d.shape != idx.shape + (3,):
            raise ValueError(f"displacements must have shape {idx.shape + (3,)} (one per "
                             f"particle), got {d.shape}")
        if np.any((idx < -1) | (idx >= len(x))):
            raise ValueError(f"particle indices must be in -1..{len(x) - 1}, got "
                             f"{idx[(idx < -1) | (idx >= len(x))][:5].tolist()}")
        none = idx == -1
        return x[np.where(none, 0, idx)] + d, none
