"""Quadratic state/control costs (Eq. 2-3 of the state-vector-reduction paper), in torch.

The state error lives in the tangent space, e = [q (-) q_ref ; v - v_ref] in R^{2 nv}, so free
and ball joints are handled like every other DoF. The cost always covers the full state
(Remark 1 of the paper): removing a DoF from the active set C changes the derivatives iLQR
sees, not what a trajectory costs.

    l(x, u)  = e^T diag(w) e + u^T diag(r) u        running cost, t = 0 .. T-1
    l_f(x)   = e^T diag(w_f) e                      terminal cost, t = T
    J(X, U)  = l_f(x_T) + sum_t l(x_t, u_t)

Optional residual terms add w_i |r_i(x)|^2 to l and l_f (e.g. the end effector's distance to
the object it should push, through torch forward kinematics); their derivatives are
Gauss-Newton (2 w J^T r, 2 w J^T J) with J from autograd.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from dopt.scene import Scene
from dopt.validation import check_real, float_array, index_array


@dataclass(frozen=True)
class CostDerivatives:
    """First and second derivatives on the active set C (2c = 2|C| tangent entries).

    lx: (T+1, 2c), lxx: (T+1, 2c, 2c), lu: (T, nu), luu: (T, nu, nu); l_ux is zero.
    """

    lx: torch.Tensor
    lxx: torch.Tensor
    lu: torch.Tensor
    luu: torch.Tensor


class EEDistanceTerm:
    """w |P (fk(q_arm) - target)|^2 with target = offset + M q_target, a linear function of
    some qpos entries (an object's position, or the mean of a soft body's vertices); with
    ``distance`` r: w (|P (fk(q_arm) - target)| - r)^2, a distance to keep rather than close.

    Only DoFs whose tangent coordinate equals their qpos coordinate may enter (hinge, slide,
    free-joint translation), so the Jacobian in qpos is the Jacobian in the tangent space.

    Args:
        scene: the scene.
        fk: callable (B, len(arm_dofs)) joint positions -> (B, 3) end-effector positions
            (torch, differentiable; e.g. a pytorch-kinematics chain).
        arm_dofs: (a,) DoFs of the arm joints, in fk's order.
        target_dofs: (k,) DoFs the target depends on; target_map: (3, k); offset: (3,).
        axes: which of x, y, z enter the distance.
        weight, terminal_weight: w in l and in l_f.
        distance: r (m), or None (the residual is the offset vector itself).
    """

    def __init__(self, scene: Scene, fk, arm_dofs, target_dofs, target_map, offset,
                 axes=(0, 1, 2), weight: float = 1.0, terminal_weight: float = 1.0,
                 distance: float | None = None):
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a dopt.Scene, got {type(scene).__name__}")
        if not callable(fk):
            raise TypeError(f"fk must be callable (B, a) -> (B, 3), got {type(fk).__name__}")
        self.arm_dofs = index_array(arm_dofs, "arm_dofs", scene.nv)
        self.target_dofs = index_array(target_dofs, "target_dofs", scene.nv, allow_empty=True)
        dofs = np.concatenate([self.arm_dofs, self.target_dofs])
        self._qadr = scene.linear_qpos_indices(dofs)
        self.fk = fk
        k = len(self.target_dofs)
        self.M = torch.as_tensor(float_array(target_map, "target_map", (3, k)))
        self.offset = torch.as_tensor(_vector(offset, 3, "offset"))
        axes = index_array(axes, "axes", 3)
        if len(np.unique(axes)) != len(axes):
            raise ValueError(f"axes must not repeat, got {axes.tolist()}")
        self.axes = axes.tolist()
        self.weight = check_real(weight, "weight", minimum=0)
        self.terminal_weight = check_real(terminal_weight, "terminal_weight", minimum=0)
        self.distance = None if distance is None else check_real(distance, "distance",
                                                                 minimum=0)
        self.dofs = dofs
        self.column = {int(d): i for i, d in enumerate(dofs)}   # DoF -> Jacobian column
        if len(self.column) != len(dofs):
            raise ValueError("arm_dofs and target_dofs overlap")

    def residual(self, qpos: torch.Tensor) -> torch.Tensor:
        """(..., nq) -> (..., len(axes)), or (..., 1) with ``distance``."""
        x = qpos[..., self._qadr]
        a = len(self.arm_dofs)
        lead = x.shape[:-1]
        ee = self.fk(x[..., :a].reshape(-1, a)).reshape(*lead, 3)
        target = self.offset + x[..., a:] @ self.M.T
        d = (ee - target)[..., self.axes]
        if self.distance is None:
            return d
        # the 1e-24 keeps the gradient finite where the two points meet
        return torch.sqrt((d ** 2).sum(-1, keepdim=True) + 1e-24) - self.distance

    def weights(self, T: int) -> torch.Tensor:
        """(T+1,) weight per row: running, then terminal."""
        w = torch.full((T + 1,), self.weight, dtype=torch.float64)
        w[-1] = self.terminal_weight
        return w


class QuadraticCost:
    """Diagonal quadratic cost on the full tangent state and the controls, plus residual terms.

    Args:
        scene: the scene whose state rows are costed.
        q_ref: (nq,) reference positions; v_ref: (nv,) reference velocities (default 0).
        w, w_f: (2nv,) running and terminal weights on [dq; dv].
        r: (nu,) control weights.
        terms: residual terms (EEDistanceTerm) added to every row's cost.
    """

    def __init__(self, scene: Scene, q_ref, w, w_f, r, v_ref=None, terms=()):
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a dopt.Scene, got {type(scene).__name__}")
        m = scene.model
        self.scene = scene
        self.q_ref = _vector(q_ref, m.nq, "q_ref")
        self.v_ref = np.zeros(m.nv) if v_ref is None else _vector(v_ref, m.nv, "v_ref")
        self.w = torch.as_tensor(_vector(w, 2 * m.nv, "w", nonneg=True))
        self.w_f = torch.as_tensor(_vector(w_f, 2 * m.nv, "w_f", nonneg=True))
        self.r = torch.as_tensor(_vector(r, m.nu, "r", nonneg=True))
        self.terms = tuple(terms)
        for term in self.terms:
            if not all(hasattr(term, a) for a in ("residual", "weights", "dofs", "column")):
                raise TypeError(f"terms must be residual terms (EEDistanceTerm), got "
                                f"{type(term).__name__}")
        self._qpos, self._qvel = scene.layout["qpos"], scene.layout["qvel"]

    @property
    def costed_dofs(self) -> np.ndarray:
        """DoFs with a non-zero running or terminal weight, or in a residual term."""
        nv = self.scene.nv
        weight = (self.w + self.w_f).numpy()
        own = np.nonzero((weight[:nv] > 0) | (weight[nv:] > 0))[0]
        return np.unique(np.concatenate([own] + [t.dofs for t in self.terms]))

    def errors(self, states: np.ndarray) -> torch.Tensor:
        """Tangent error of state rows: (..., ns) -> (..., 2nv)."""
        return self._errors(self._states(states))

    def _errors(self, states: np.ndarray) -> torch.Tensor:
        q, v = states[..., self._qpos], states[..., self._qvel]
        dq = self.scene.tangent.difference(self.q_ref, q)
        return torch.from_numpy(np.concatenate([dq, v - self.v_ref], axis=-1))

    def total(self, states: np.ndarray, controls: np.ndarray) -> torch.Tensor:
        """J of trajectories: states (..., T+1, ns), controls (..., T, nu) -> (...)."""
        states, controls = self._trajectories(states, controls)
        e = self._errors(states)
        u = torch.as_tensor(controls)
        running = (e[..., :-1, :] ** 2 * self.w).sum(-1) + (u ** 2 * self.r).sum(-1)
        total = running.sum(-1) + (e[..., -1, :] ** 2 * self.w_f).sum(-1)
        if self.terms:
            qpos = torch.from_numpy(np.ascontiguousarray(states[..., self._qpos]))
            T = u.shape[-2]
            with torch.no_grad():
                for term in self.terms:
                    total = total + ((term.residual(qpos) ** 2).sum(-1) * term.weights(T)).sum(-1)
        return total

    def derivatives(self, states: np.ndarray, controls: np.ndarray,
                    dofs: np.ndarray) -> CostDerivatives:
        """Derivatives along one trajectory, on the active set: states (T+1, ns), controls
        (T, nu), dofs (c,) -> CostDerivatives. Gauss-Newton in the tangent space."""
        states, controls = self._trajectories(states, controls)
        if states.ndim != 2:
            raise ValueError(f"states must have shape (T+1, {self.scene.nstate}) (one "
                             f"trajectory), got {states.shape}")
        idx = torch.as_tensor(self.scene.tangent_indices(dofs))
        e = self._errors(states)[:, idx]                                   # (T+1, 2c)
        w = torch.cat([self.w[idx].expand(len(e) - 1, -1), self.w_f[idx][None]], 0)
        u = torch.as_tensor(controls)
        lx, lxx = 2 * w * e, torch.diag_embed(2 * w)
        if self.terms:
            C = self.scene.as_dofs(dofs)
            qpos = torch.from_numpy(np.ascontiguousarray(states[:, self._qpos]))
            for term in self.terms:
                at = np.nonzero(np.isin(C, term.dofs))[0]       # positions of C in the term
                if not len(at):
                    continue
                cols = [term.column[d] for d in C[at]]
                J, r = _residual_jacobian(term, qpos)          # (T+1, na, ndofs), (T+1, na)
                J = J[:, :, cols]
                wt = term.weights(len(u))[:, None]
                at_t = torch.as_tensor(at)
                lx[:, at_t] += 2 * wt * torch.einsum("tad,ta->td", J, r)
                lxx[:, at_t[:, None], at_t[None, :]] += 2 * wt[:, :, None] * \
                    torch.einsum("tad,tae->tde", J, J)
        return CostDerivatives(lx=lx, lxx=lxx, lu=2 * self.r * u,
                               luu=torch.diag_embed(2 * self.r).expand(len(u), -1, -1))


    def _states(self, states) -> np.ndarray:
        """State rows (..., ns) as float64, finite; ValueError naming ``states``."""
        x = float_array(states, "states")
        if x.shape[-1:] != (self.scene.nstate,):
            raise ValueError(f"states must have shape (..., {self.scene.nstate}), got {x.shape}")
        return x

    def _trajectories(self, states, controls) -> tuple[np.ndarray, np.ndarray]:
        """states (..., T+1, ns), controls (..., T, nu), checked against each other."""
        x, u, nu = self._states(states), float_array(controls, "controls"), self.scene.nu
        if x.ndim < 2:
            raise ValueError(f"states must have shape (..., T+1, {self.scene.nstate}), got "
                             f"{x.shape}")
        if u.ndim < 2 or u.shape[-1] != nu or u.shape[-2] != x.shape[-2] - 1:
            raise ValueError(f"controls must have shape (..., {x.shape[-2] - 1}, {nu}) (T, nu "
                             f"for the T+1 state rows), got {u.shape}")
        try:
            np.broadcast_shapes(x.shape[:-2], u.shape[:-2])
        except ValueError:
            raise ValueError(f"states {x.shape} and controls {u.shape} have leading "
                             f"dimensions that do not broadcast") from None
        return x, u


def _residual_jacobian(term: EEDistanceTerm, qpos: torch.Tensor):
    """d residual / d term.dofs at each row: (B, nq) -> J (B, na, ndofs), r (B, na)."""
    x = qpos[:, term._qadr].clone().requires_grad_(True)
    full = qpos.detach().clone()

    def f(xs):
        q = full.clone()
        q[:, term._qadr] = xs
        return term.residual(q)

    r = f(x)
    rows = [torch.autograd.grad(r[:, i].sum(), x, retain_graph=True)[0]
            for i in range(r.shape[1])]
    return torch.stack(rows, dim=1).detach(), r.detach()


def _vector(x, n: int, name: str, nonneg: bool = False) -> np.ndarray:
    return float_array(x, name, (n,), nonnegative=nonneg)
