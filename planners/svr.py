"""DoF importance from the feedback gains K and the DoF-selection methods (Sec. 4.2, 5).

Importance (per DoF j of the active set C, c = |C|, from K of shape (T, nu, 2c)):

- ``sum`` (Eq. 15): sum over t and controls of |K_t(p, j)| + |K_t(p, j + c)|, over T;
- ``svd`` (Eq. 17): K_t = U S V^T; sum over t and the first g singular triplets of
  (|V_t(j, n)| + |V_t(j + c, n)|) sigma_n, over T.

The paper writes both without absolute values; gains of either sign matter equally, and the
sign of a singular vector is arbitrary, so magnitudes are used (as the authors' code does).

Methods by name: ``baseline`` (all DoFs), ``rand`` (the robot plus theta random DoFs, redrawn
every iteration), ``naive`` (the robot plus the DoFs the cost weights), ``svr-sum`` and
``svr-svd`` (start from all DoFs; before each optimisation re-add theta random unused DoFs;
after it remove the DoFs whose importance is below rho). Robot DoFs are never removed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from dopt.mpc import Plan
from dopt.validation import check_config, check_int, index_array

METHODS = ("baseline", "rand", "naive", "svr-sum", "svr-svd")


def _gains(K, name: str = "K") -> torch.Tensor:
    """K as a (T, nu, 2c) floating torch tensor with T, nu, c >= 1 and finite entries."""
    if not torch.is_tensor(K):
        arr = np.asarray(K)
        if arr.dtype.kind not in "f":
            raise TypeError(f"{name} must be a float tensor (T, nu, 2c), got "
                            f"{type(K).__name__} of dtype {arr.dtype}")
        K = torch.from_numpy(np.ascontiguousarray(arr))
    if not K.is_floating_point():
        raise TypeError(f"{name} must be a float tensor (T, nu, 2c), got dtype {K.dtype}")
    if K.ndim != 3 or min(K.shape) < 1 or K.shape[-1] % 2:
        raise ValueError(f"{name} must have shape (T, nu, 2c) with T, nu, c >= 1, got "
                         f"{tuple(K.shape)}")
    if not torch.isfinite(K).all():
        raise ValueError(f"{name} contains NaN/inf")
    return K


def importance_sum(K: torch.Tensor) -> torch.Tensor:
    """Eq. 15: (T, nu, 2c) -> (c,)."""
    K = _gains(K)
    c = K.shape[-1] // 2
    a = K.abs().sum(dim=(0, 1))
    return (a[:c] + a[c:]) / K.shape[0]


def importance_svd(K: torch.Tensor, g: int = 3) -> torch.Tensor:
    """Eq. 17 with the first g singular values: (T, nu, 2c) -> (c,)."""
    K = _gains(K)
    check_int(g, "g", minimum=1)
    c = K.shape[-1] // 2
    _, S, Vh = torch.linalg.svd(K, full_matrices=False)     # S (T, r), Vh (T, r, 2c)
    g = min(g, S.shape[-1])
    w = (Vh[:, :g, :].abs() * S[:, :g, None]).sum(dim=(0, 1))  # (2c,)
    return (w[:c] + w[c:]) / K.shape[0]


# theta per method in the paper's Table 1 (rand: 5 random DoFs besides the robot; SVR: 10
# re-introduced per iteration); the experiments and the bench default to these
PAPER_THETA = {"rand": 5, "svr-sum": 10, "svr-svd": 10}


def paper_theta(method: str) -> int:
    """The paper's theta for ``method`` (0 for methods that draw no random DoFs)."""
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose from {METHODS}")
    return PAPER_THETA.get(method, 0)


@dataclass(frozen=True)
class SelectionConfig:
    """method: one of METHODS; rho: importance threshold below which SVR removes a DoF;
    theta: random unused DoFs (re-)introduced per iteration (rand: DoFs besides the robot);
    g: singular values used by svr-svd; keep_costed: the DoFs the cost weights are always in
    the set, as the robot's (rand and SVR; beyond the paper: a goal object cut from C cannot
    be moved toward its goal by that optimisation). The defaults are the paper's svr-sum row
    of Table 1 (rho 1, theta 10); ``paper_theta(method)`` gives any method's theta."""

    method: str = "svr-sum"
    rho: float = 1.0
    theta: int = 10
    g: int = 3
    keep_costed: bool = False

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"unknown method {self.method!r}; choose from {METHODS}")
        check_config(self, minimum={"rho": 0.0, "theta": 0, "g": 1})


class DofSelector:
    """Keeps the active DoF set C of one MPC run (Alg. 1 lines 1, 6-8 and 10-12).

    Args:
        nv: number of DoFs.
        robot: (r,) robot DoFs, always active.
        costed: DoFs the cost weights (for ``naive``).
        config: the method and its parameters.
        rng: the generator of every random choice.
    """

    def __init__(self, nv: int, robot, costed, config: SelectionConfig,
                 rng: np.random.Generator):
        if not isinstance(rng, np.random.Generator):
            raise TypeError("rng must be a numpy.random.Generator")
        if not isinstance(config, SelectionConfig):
            raise TypeError(f"config must be a SelectionConfig, got {type(config).__name__}")
        nv = check_int(nv, "nv", minimum=1)
        self.nv, self.config, self.rng = nv, config, rng
        self.robot = np.unique(index_array(robot, "robot", nv, allow_empty=True))
        costed = index_array(costed, "costed", nv, allow_empty=True)
        # DoFs never dropped: the robot's, and with keep_costed those the cost weights
        self.kept = np.union1d(self.robot, costed) if config.keep_costed else self.robot
        if config.method == "naive":
            self.active = np.union1d(self.robot, costed)
        else:
            self.active = np.arange(nv)   # baseline and SVR start from F (rand redraws)
        self.importance: np.ndarray | None = None

    def before(self) -> np.ndarray:
        """The DoF set for the next optimisation (adds theta random unused DoFs for SVR)."""
        method, theta = self.config.method, self.config.theta
        if method == "rand":
            others = np.setdiff1d(np.arange(self.nv), self.kept)
            pick = self.rng.choice(others, size=min(theta, len(others)), replace=False)
            self.active = np.union1d(self.kept, pick)
        elif method.startswith("svr"):
            unused = np.setdiff1d(np.arange(self.nv), self.active)
            if len(unused) and theta:
                pick = self.rng.choice(unused, size=min(theta, len(unused)), replace=False)
                self.active = np.union1d(self.active, pick)
        return self.active

    def after(self, K: torch.Tensor, dofs: np.ndarray) -> np.ndarray:
        """Remove DoFs of ``dofs`` below rho given their gains K (T, nu, 2|dofs|) (SVR only)."""
        method = self.config.method
        if not method.startswith("svr"):
            return self.active
        dofs = index_array(dofs, "dofs", self.nv)
        K = _gains(K)
        if K.shape[-1] != 2 * len(dofs):
            raise ValueError(f"K has {K.shape[-1]} columns for {len(dofs)} dofs; it must have "
                             f"2 |dofs| = {2 * len(dofs)}")
        imp = importance_sum(K) if method == "svr-sum" else importance_svd(K, self.config.g)
        self.importance = imp.numpy()
        keep = (self.importance >= self.config.rho) | np.isin(dofs, self.kept)
        self.active = np.asarray(dofs)[keep]
        return self.active


class SVROptimiser:
    """One MPC optimisation of Alg. 1 (lines 5-12): update the DoF set, run one iLQR
    iteration on it, drop unimportant DoFs. Implements dopt.mpc.Optimiser.

    Args:
        ilqr: a planners.ilqr.ILQR.
        selector: the DofSelector of this run.

    ``n_unstable_rollouts`` counts the line-search rollouts the stability verdict flagged.
    With ``keep_history``, ``history`` gets one entry per optimisation: {"dofs": the set it
    optimised (c,), "importance": the importance of each of them (c,) for SVR, else None,
    "alpha": the accepted line-search step (0: rejected), "mu": the regularisation after it,
    "cost_before", "cost_after": J of the old and the new nominal}, and, with a ``probe``
    (a function of the new nominal's (T+1, ns) states returning a dict), that dict's items.
    """

    def __init__(self, ilqr, selector: DofSelector, keep_history: bool = False,
                 probe=None):
        if not callable(getattr(ilqr, "iterate", None)):
            raise TypeError(f"ilqr must be a planners.ilqr.ILQR (with iterate), got "
                            f"{type(ilqr).__name__}")
        if not isinstance(selector, DofSelector):
            raise TypeError(f"selector must be a DofSelector, got {type(selector).__name__}")
        self.ilqr, self.selector = ilqr, selector
        self.n_unstable_rollouts = 0
        self.keep_history, self.history = bool(keep_history), []
        if probe is not None and not callable(probe):
            raise TypeError(f"probe must be callable or None, got {type(probe).__name__}")
        self.probe = probe

    def optimise(self, state: np.ndarray, plan: Plan) -> Plan:
        C = self.selector.before()
        step = self.ilqr.iterate(state, plan.controls, C)
        self.selector.after(step.K, step.dofs)
        self.n_unstable_rollouts += step.n_unstable
        if self.keep_history:
            imp = self.selector.importance
            entry = {"dofs": np.asarray(step.dofs).tolist(),
                     "importance": None if imp is None or len(imp) != len(step.dofs)
                     else np.asarray(imp, dtype=float).tolist(),
                     "alpha": float(step.alpha), "mu": float(step.mu),
                     "cost_before": float(step.cost_before),
                     "cost_after": float(step.cost_after)}
            if self.probe is not None:
                entry.update(self.probe(step.states))
            self.history.append(entry)
        info = dict(step.seconds, cost=step.cost_after, alpha=step.alpha, n_dofs=len(C))
        return Plan(controls=step.controls, states=step.states, K=step.K.numpy(),
                    dofs=step.dofs, info=info)
