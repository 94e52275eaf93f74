"""Quadratic state/control costs (Eq. 2-3 of the state-vector-reduction paper), in torch.

The state error lives in the tangent space, e = [q (-) q_ref ; v - v_ref] in R^{2 nv}, so free
and ball joints are handled like every other DoF. The cost always covers the full state
(Remark 1 of the paper): removing a DoF from the active set C changes the derivatives iLQR
sees, not what a trajectory costs.

    l(x, u)  = e^T diag(w) e + u^T diag(r) u        running cost, t = 0 .. T-1
    l_f(x)   = e^T diag(w_f) e                      terminal cost, t = T
    J(X, U)  = l_f(x_T) + sum_t l(x_t, u_t)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from dopt.scene import Scene


@dataclass(frozen=True)
class CostDerivatives:
    """First and second derivatives on the active set C (2c = 2|C| tangent entries).

    lx: (T+1, 2c), lxx: (T+1, 2c, 2c), lu: (T, nu), luu: (T, nu, nu); l_ux is zero.
    """

    lx: torch.Tensor
    lxx: torch.Tensor
    lu: torch.Tensor
    luu: torch.Tensor


class QuadraticCost:
    """Diagonal quadratic cost on the full tangent state and the controls.

    Args:
        scene: the scene whose state rows are costed.
        q_ref: (nq,) reference positions; v_ref: (nv,) reference velocities (default 0).
        w, w_f: (2nv,) running and terminal weights on [dq; dv].
        r: (nu,) control weights.
    """

    def __init__(self, scene: Scene, q_ref, w, w_f, r, v_ref=None):
        m = scene.model
        self.scene = scene
        self.q_ref = _vector(q_ref, m.nq, "q_ref")
        self.v_ref = np.zeros(m.nv) if v_ref is None else _vector(v_ref, m.nv, "v_ref")
        self.w = torch.as_tensor(_vector(w, 2 * m.nv, "w", nonneg=True))
        self.w_f = torch.as_tensor(_vector(w_f, 2 * m.nv, "w_f", nonneg=True))
        self.r = torch.as_tensor(_vector(r, m.nu, "r", nonneg=True))
        self._qpos, self._qvel = scene.layout["qpos"], scene.layout["qvel"]

    @property
    def costed_dofs(self) -> np.ndarray:
        """DoFs with a non-zero running or terminal weight (what the 'naive' method keeps)."""
        nv = self.scene.nv
        weight = (self.w + self.w_f).numpy()
        return np.nonzero((weight[:nv] > 0) | (weight[nv:] > 0))[0]

    def errors(self, states: np.ndarray) -> torch.Tensor:
        """Tangent error of state rows: (..., ns) -> (..., 2nv)."""
        q, v = states[..., self._qpos], states[..., self._qvel]
        dq = self.scene.tangent.difference(self.q_ref, q)
        return torch.from_numpy(np.concatenate([dq, v - self.v_ref], axis=-1))

    def total(self, states: np.ndarray, controls: np.ndarray) -> torch.Tensor:
        """J of trajectories: states (..., T+1, ns), controls (..., T, nu) -> (...)."""
        e = self.errors(states)
        u = torch.as_tensor(controls)
        running = (e[..., :-1, :] ** 2 * self.w).sum(-1) + (u ** 2 * self.r).sum(-1)
        return running.sum(-1) + (e[..., -1, :] ** 2 * self.w_f).sum(-1)

    def derivatives(self, states: np.ndarray, controls: np.ndarray,
                    dofs: np.ndarray) -> CostDerivatives:
        """Derivatives along one trajectory, on the active set: states (T+1, ns), controls
        (T, nu), dofs (c,) -> CostDerivatives. Gauss-Newton in the tangent space."""
        idx = torch.as_tensor(self.scene.tangent_indices(dofs))
        e = self.errors(states)[:, idx]                                   # (T+1, 2c)
        w = torch.cat([self.w[idx].expand(len(e) - 1, -1), self.w_f[idx][None]], 0)
        u = torch.as_tensor(controls)
        return CostDerivatives(lx=2 * w * e, lxx=torch.diag_embed(2 * w),
                               lu=2 * self.r * u,
                               luu=torch.diag_embed(2 * self.r).expand(len(u), -1, -1))


def _vector(x, n: int, name: str, nonneg: bool = False) -> np.ndarray:
    arr = np.asarray(x, dtype=np.float64)
    if arr.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN/inf")
    if nonneg and np.any(arr < 0):
        raise ValueError(f"{name} must be non-negative")
    return arr
