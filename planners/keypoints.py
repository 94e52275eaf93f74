"""Derivatives over time: finite differences at key timesteps only, linear in between.

The state-vector-reduction paper reduces the derivatives over DoFs; its authors' next step
(TrajOptKP, "key points") reduces them over time: A and B are computed by finite differences
at chosen timesteps and linearly interpolated between them. Stacked on SVR, iLQR then
differentiates |C| DoFs at a fraction of the T timesteps.

Methods (``KeypointConfig.method``):

- ``every``: every timestep (plain finite differences);
- ``skip``: every ``skip``-th timestep (MuJoCo MPC's ``derivative_skip``);
- ``adaptive``: a timestep becomes a key point when the velocity of some active DoF has
  changed by more than ``threshold`` since the last key point, or changes direction (its
  acceleration changes sign: the velocity profile turns), no sooner than ``min_interval``
  and no later than ``max_interval`` steps after the last key point.

The first and the last timestep are always key points. Shapes: T timesteps, k key points,
c = |C|, n = 2c, nu controls, ns a state row.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from dopt.scene import Scene
from dopt.validation import check_config

METHODS = ("every", "skip", "adaptive")


@dataclass(frozen=True)
class KeypointConfig:
    """method: ``every``, ``skip`` or ``adaptive`` (module docstring). skip: the interval of
    ``skip``. min_interval, max_interval, threshold: the rules of ``adaptive`` (threshold in
    each DoF's velocity unit, m/s or rad/s)."""

    method: str = "every"
    skip: int = 1
    min_interval: int = 1
    max_interval: int = 10
    threshold: float = 0.1

    @classmethod
    def parse(cls, name: str) -> KeypointConfig:
        """``every``, ``skip<K>`` or ``adaptive`` (the bench's and CLI's spelling)."""
        if name in ("every", "adaptive"):
            return cls(name)
        if name.startswith("skip") and name[4:].isdigit() and int(name[4:]) >= 1:
            return cls("skip", skip=int(name[4:]))
        raise ValueError(f"keypoint variant must be every, skip<K> (K >= 1) or adaptive, got "
                         f"{name!r}")

    @property
    def name(self) -> str:
        return f"skip{self.skip}" if self.method == "skip" else self.method

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"keypoint method must be one of {METHODS}, got {self.method!r}")
        check_config(self, positive=("threshold",),
                     minimum={"skip": 1, "min_interval": 1, "max_interval": 1})
        if self.min_interval > self.max_interval:
            raise ValueError(f"min_interval ({self.min_interval}) must be <= max_interval "
                             f"({self.max_interval})")


def key_steps(config: KeypointConfig, scene: Scene, states: np.ndarray,
              dofs: np.ndarray) -> np.ndarray:
    """The key timesteps (k,) in 0..T-1, sorted, first and last included, for the nominal
    states (T+1, ns) and the active DoFs (c,)."""
    T = len(states) - 1
    if T < 1:
        raise ValueError(f"states must have T+1 >= 2 rows, got {len(states)}")
    if config.method == "every" or (config.method == "skip" and config.skip == 1):
        return np.arange(T)
    if config.method == "skip":
        return np.unique(np.append(np.arange(0, T, config.skip), T - 1))
    v = states[:T, scene.layout["qvel"]][:, dofs]                 # (T, c)
    acc = np.diff(v, axis=0)                                       # acc[t-1] = v_t - v_{t-1}
    keys, last = [0], 0
    for t in range(1, T):
        gap = t - last
        if gap < config.min_interval:
            continue
        turned = t >= 2 and bool(np.any(acc[t - 1] * acc[t - 2] < 0))
        moved = bool(np.any(np.abs(v[t] - v[last]) > config.threshold))
        if gap >= config.max_interval or turned or moved:
            keys.append(t)
            last = t
    if keys[-1] != T - 1:
        keys.append(T - 1)
    return np.asarray(keys)


def interpolate(F: torch.Tensor, keys: np.ndarray, T: int) -> torch.Tensor:
    """F (k, n, n+nu) at the key timesteps -> (T, n, n+nu): the key rows as they are, the
    others the linear blend of the two key rows around them."""
    keys = np.asarray(keys)
    if len(keys) == T:
        return F
    t = np.arange(T)
    right = np.clip(np.searchsorted(keys, t, side="left"), 1, len(keys) - 1)
    left = right - 1
    span = (keys[right] - keys[left]).astype(float)
    w = torch.from_numpy((t - keys[left]) / np.where(span > 0, span, 1.0)).to(F.dtype)
    w = w[:, None, None]
    out = (1 - w) * F[torch.from_numpy(left)] + w * F[torch.from_numpy(right)]
    on_key = np.isin(t, keys)
    out[torch.from_numpy(on_key)] = F[torch.from_numpy(np.searchsorted(keys, t[on_key]))]
    return out
