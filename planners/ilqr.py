"""iLQR with state-vector reduction (iLQR-SVR, Sec. 4.1 of the state-vector-reduction paper).

Derivatives A^C, B^C come from the rollout service for the active DoF set C only; the cost
derivatives and the backward pass (Eq. 8-10) run in torch on the reduced tangent state
x^C = [q_C; v_C] (2|C|); the forward pass rolls the full nonlinear model out with the reduced
feedback u = u_bar + alpha k + K^C (x_hat^C - x^C) (Eq. 11-13), one rollout per line-search
alpha, all alphas in one lock-stepped batch. With C = all DoFs this is plain iLQR.

Shapes: T horizon, nu controls, c = |C|, n = 2c, ns state row, A alphas.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import torch

from dopt.costs import QuadraticCost
from dopt.rollout import FDConfig, RolloutService
from dopt.validation import check_config, check_int, check_real, float_array
from planners.keypoints import METHODS as KEYPOINT_METHODS
from planners.keypoints import KeypointConfig, interpolate, key_steps

log = logging.getLogger(__name__)


def _default_alphas() -> tuple[float, ...]:
    """The authors' 7 line-search step sizes, alpha_i = (i/7)^2, largest first."""
    return tuple((i / 7) ** 2 for i in range(7, 0, -1))


#: the finite differences by name: forward eps 1e-3 (``FDConfig``'s default, where its
#: docstring says why not the authors' step) or the authors' central differences, eps 1e-6
FINITE_DIFFERENCES = {"forward": FDConfig(), "central": FDConfig(1e-6, centered=True)}


@dataclass(frozen=True)
class Derivatives:
    """How iLQR differentiates the dynamics, one typed value from a command line's flags to
    the backward pass (``ILQRConfig.derivatives``).

    Attributes:
        fd: the finite differences, a name of ``FINITE_DIFFERENCES`` (``forward``,
            ``central``).
        keypoints: the timesteps they cover (``planners.keypoints``): ``every``, ``skip``
            (every ``fd_skip``-th) or ``adaptive`` (its default rules); A and B linear
            between.
        fd_skip: the interval of ``skip`` (1 with the other two).
        box_qp: the backward pass solves a box-constrained QP per step for the control limits
            (``mujoco.mju_boxQP``; the gains of clamped controls are 0, as in MuJoCo MPC's
            iLQG), instead of leaving the limits to the clamping of the simulator.
        fd_eps: the finite-difference step where it is not the named difference's own; None
            (also what the named step normalises to): the named one's.
    """

    fd: Literal["forward", "central"] = "forward"
    keypoints: Literal["every", "skip", "adaptive"] = "every"
    fd_skip: int = 1
    box_qp: bool = False
    fd_eps: float | None = None

    def __post_init__(self):
        check_config(self, positive=("fd_eps",), minimum={"fd_skip": 1},
                     choices={"fd": tuple(FINITE_DIFFERENCES), "keypoints": KEYPOINT_METHODS})
        if self.keypoints != "skip" and self.fd_skip != 1:
            raise ValueError(f"Derivatives.fd_skip must be 1 with keypoints "
                             f"{self.keypoints!r} (a skip needs keypoints 'skip'), got "
                             f"{self.fd_skip}")
        if self.fd_eps is not None:
            FDConfig(float(self.fd_eps))                       # ValueError: a step too small
            if float(self.fd_eps) == FINITE_DIFFERENCES[self.fd].eps:
                object.__setattr__(self, "fd_eps", None)

    @property
    def fd_config(self) -> FDConfig:
        """The finite differences as the rollout service takes them."""
        named = FINITE_DIFFERENCES[self.fd]
        return named if self.fd_eps is None else FDConfig(float(self.fd_eps), named.centered)

    @property
    def keypoint_config(self) -> KeypointConfig:
        """The key timesteps as ``planners.keypoints.key_steps`` takes them."""
        return KeypointConfig(self.keypoints, skip=self.fd_skip)

    def fields(self) -> dict:
        """These options as flat fields (the MPC settings' and a trial's params): fd_centered,
        fd_eps, keypoints, fd_skip, box_qp; ``from_fields`` reads them back."""
        fd = self.fd_config
        return {"fd_centered": fd.centered, "fd_eps": fd.eps, "keypoints": self.keypoints,
                "fd_skip": self.fd_skip, "box_qp": self.box_qp}

    @classmethod
    def from_fields(cls, fields) -> Derivatives:
        """The options of flat fields (``fields``' names; a missing one at its default, as
        in older params): ``Derivatives.from_fields(d.fields()) == d``."""
        plain = cls().fields()
        get = {k: fields.get(k, v) for k, v in plain.items()}
        fd = "central" if get["fd_centered"] else "forward"
        return cls(fd, get["keypoints"], get["fd_skip"], get["box_qp"], get["fd_eps"])


@dataclass(frozen=True)
class ILQRConfig:
    """derivatives: how the dynamics are differentiated (``Derivatives``: the finite
    differences, default forward eps 1e-3; the timesteps they cover, default every one; the
    box-QP backward pass for the control limits).
    mu_init/mu_min/mu_max/mu_factor: Levenberg-Marquardt regularisation of Q_uu (authors:
    0.1, 1e-4..10, x10); mu_reset: every ``iterate`` starts from mu_init (beyond the paper: in
    MPC a mu left at its cap by rejected steps makes later steps nil; the authors' and the
    default keep mu between calls). alphas: line-search step sizes tried in parallel."""

    derivatives: Derivatives = Derivatives()
    mu_init: float = 0.1
    mu_min: float = 1e-4
    mu_max: float = 10.0
    mu_factor: float = 10.0
    mu_reset: bool = False
    alphas: tuple[float, ...] = field(default_factory=_default_alphas)

    def __post_init__(self):
        if not isinstance(self.derivatives, Derivatives):
            raise TypeError(f"ILQRConfig.derivatives must be a Derivatives, got "
                            f"{self.derivatives!r}")
        check_config(self)
        if not 0 <= self.mu_min <= self.mu_init <= self.mu_max:
            raise ValueError("need 0 <= mu_min <= mu_init <= mu_max")
        if self.mu_factor <= 1:
            raise ValueError("mu_factor must be > 1")
        if not self.alphas or any(not 0 < a <= 1 for a in self.alphas):
            raise ValueError(f"alphas must be in (0, 1], got {self.alphas}")


@dataclass(frozen=True)
class ILQRStep:
    """One iteration. controls (T, nu) and states (T+1, ns): the new nominal (the old one
    when no alpha improved); K (T, nu, 2c), k (T, nu): the gains of the backward pass; dofs
    (c,): the active set; cost_before/cost_after: J of the old and new nominal; alpha: the
    accepted step (0 if rejected); mu: the regularisation used; seconds: wall time of
    'derivatives', 'backward', 'forward'; n_unstable: line-search rollouts the stability
    verdict flagged (scored +inf, never accepted); fd_steps: the timesteps the finite
    differences covered (T unless key points are chosen); nominal_unstable: the old nominal's
    rollout broke a stability bound, so its cost was no bar (any stable alpha was accepted:
    ``ILQR.iterate``)."""

    controls: np.ndarray
    states: np.ndarray
    K: torch.Tensor
    k: torch.Tensor
    dofs: np.ndarray
    cost_before: float
    cost_after: float
    alpha: float
    mu: float
    seconds: dict
    n_unstable: int = 0
    fd_steps: int = 0
    nominal_unstable: bool = False

    @property
    def accepted(self) -> bool:
        return self.alpha > 0


@dataclass(frozen=True)
class ILQRResult:
    """controls (T, nu), states (T+1, ns), costs: J after each iteration (iteration 0 is the
    initial guess), steps: every ILQRStep."""

    controls: np.ndarray
    states: np.ndarray
    costs: list
    steps: list


class ILQR:
    """iLQR on a reduced DoF set over a RolloutService and a QuadraticCost.

    ``iterate`` runs one iteration (the MPC mode); ``solve`` iterates to convergence. The
    regularisation mu persists between calls, as in an MPC loop.
    """

    def __init__(self, service: RolloutService, cost: QuadraticCost,
                 config: ILQRConfig = ILQRConfig()):
        if not isinstance(config, ILQRConfig):
            raise TypeError(f"config must be an ILQRConfig, got {type(config).__name__}")
        for name, obj, kind in (("service", service, "RolloutService"),
                                ("cost", cost, "QuadraticCost")):
            if not hasattr(obj, "scene"):
                raise TypeError(f"{name} must be a {kind} (with a scene), got "
                                f"{type(obj).__name__}")
        if cost.scene is not service.scene:
            raise ValueError("cost and rollout service must share one Scene")
        self.service, self.cost, self.config = service, cost, config
        self.mu = config.mu_init
        self._alphas = np.asarray(config.alphas, dtype=float)

    def iterate(self, x0: np.ndarray, controls: np.ndarray, dofs=None,
                nominal: np.ndarray | None = None) -> ILQRStep:
        """One iteration from state x0 (ns,) and controls (T, nu) on the DoF set ``dofs``
        (None: all). ``nominal`` (T+1, ns) may pass the trajectory of these controls if the
        caller has it; otherwise it is rolled out, and judged: a nominal whose rollout breaks
        a stability bound (``dopt.stability``) has no valid cost past that step, so the line
        search accepts the cheapest stable alpha whatever its cost (a plan the simulation can
        be trusted on beats one it cannot), instead of comparing with an invalid J.

        Raises:
            TypeError / ValueError: controls that are not a finite (T, nu) float array with
                T >= 1, a nominal that is not (T+1, ns), bad DoFs or a bad x0 (the rollout
                service's checks).
        """
        if self.config.mu_reset:
            self.mu = self.config.mu_init
        svc, scene = self.service, self.service.scene
        C = scene.dofs() if dofs is None else scene.as_dofs(dofs)
        U = _controls(controls, scene.nu)
        unstable = False
        if nominal is None:
            traj = svc.trajectory(x0, U)
            X = traj.states
            unstable = bool(traj.stability.n_unstable)
            if unstable:
                log.warning("iLQR: the nominal rollout is unstable (step %d: %s); any stable "
                            "line-search step replaces it", traj.stability.step[0],
                            traj.stability.reason[0])
        else:
            X = float_array(nominal, "nominal", (len(U) + 1, None))
        J0 = float(self.cost.total(X, U))

        t0 = time.perf_counter()
        how = self.config.derivatives
        keys = key_steps(how.keypoint_config, scene, X, C)
        D = svc.derivatives(X[keys], C, how.fd_config)
        if D.stability is not None and D.stability.n_unstable:
            log.warning("iLQR: derivatives around an unstable nominal state (key step %d: %s)",
                        keys[D.stability.step[0]], D.stability.reason[0])
        F = interpolate(torch.from_numpy(D.F), keys, len(U))     # part of the derivatives' time
        t1 = time.perf_counter()
        cd = self.cost.derivatives(X, U, C)
        limits = _limits(scene.model, U) if how.box_qp else None
        with torch.inference_mode():   # no autograd bookkeeping: ~20 % of a small op's cost
            while True:
                gains = backward_pass(F, cd.lx, cd.lxx, cd.lu, cd.luu, self.mu, limits)
                if gains is not None or self.mu >= self.config.mu_max:
                    break
                self.mu = min(self.mu * self.config.mu_factor, self.config.mu_max)
        t2 = time.perf_counter()
        if gains is None:
            log.warning("backward pass failed at mu=%g; keeping the nominal", self.mu)
            return ILQRStep(U, X, torch.zeros(len(U), scene.nu, 2 * len(C)),
                            torch.zeros(len(U), scene.nu), C, J0, J0, 0.0, self.mu,
                            {"derivatives": t1 - t0, "backward": t2 - t1, "forward": 0.0},
                            0, len(keys), unstable)
        K, k = gains
        ff = U[None] + self._alphas[:, None, None] * k.numpy()[None]     # (A, T, nu)
        trial = svc.rollout_feedback(x0, ff, X[:-1], K.numpy(), C)
        costs = self.cost.total(trial.states, trial.controls).numpy()    # (A,)
        flagged = trial.stability.unstable
        costs = np.where(flagged, np.inf, costs)
        if flagged.any():
            log.debug("iLQR line search: %d of %d alphas unstable (%s)", int(flagged.sum()),
                      len(flagged), trial.stability.first()[2])
        t3 = time.perf_counter()
        best = int(np.argmin(costs))
        seconds = {"derivatives": t1 - t0, "backward": t2 - t1, "forward": t3 - t2}
        if costs[best] < (np.inf if unstable else J0):
            self.mu = max(self.mu / self.config.mu_factor, self.config.mu_min)
            return ILQRStep(trial.controls[best], trial.states[best], K, k, C, J0,
                            float(costs[best]), float(self._alphas[best]), self.mu, seconds,
                            int(flagged.sum()), len(keys), unstable)
        self.mu = min(self.mu * self.config.mu_factor, self.config.mu_max)
        return ILQRStep(U, X, K, k, C, J0, J0, 0.0, self.mu, seconds, int(flagged.sum()),
                        len(keys), unstable)

    def solve(self, x0: np.ndarray, controls: np.ndarray, dofs=None, max_iterations: int = 50,
              rtol: float = 1e-6) -> ILQRResult:
        """Iterate until the relative improvement drops below rtol after an accepted step,
        the regularisation saturates, or max_iterations."""
        check_int(max_iterations, "max_iterations", minimum=1)
        check_real(rtol, "rtol", minimum=0.0)
        U, X = _controls(controls, self.service.scene.nu), None
        steps, costs = [], []
        for _ in range(max_iterations):
            step = self.iterate(x0, U, dofs, nominal=X)
            steps.append(step)
            if not costs:
                costs.append(step.cost_before)
            costs.append(step.cost_after)
            U, X = step.controls, step.states
            if step.nominal_unstable and not step.accepted:
                X = None                 # judge it again next time (an accepted step is stable)
            gain = (step.cost_before - step.cost_after) / max(abs(step.cost_before), 1e-300)
            if step.accepted and not step.nominal_unstable and gain < rtol:
                break
            if not step.accepted and self.mu >= self.config.mu_max:
                break
        return ILQRResult(U, X, costs, steps)


def backward_pass(F: torch.Tensor, lx: torch.Tensor, lxx: torch.Tensor, lu: torch.Tensor,
                  luu: torch.Tensor, mu: float, limits=None):
    """Riccati recursion (Eq. 8-10) on the reduced state with Q_uu + mu I.

    F (T, n, n+nu) = [A B] (``Derivatives.F``), lx (T+1, n), lxx (T+1, n, n), lu (T, nu),
    luu (T, nu, nu). Returns (K (T, nu, n), k (T, nu)), or None if some Q_uu + mu I is not
    positive definite.

    limits: None, or (lower, upper) (T, nu) bounds on the control step du = k + K dx: then k
    minimises the step's quadratic model within them (``mujoco.mju_boxQP``) and K is the
    unconstrained gain on the controls the QP leaves free, 0 on the clamped ones.

    Each step forms all Q blocks at once: Q = blkdiag(lxx, luu) + F^T V' F and
    q = [lx; lu] + F^T V'_x (l_ux = 0), with F^T as a view (no transposed copy of F), which
    keeps the number of small torch calls, and the bytes copied, low.
    """
    if not (np.isfinite(mu) and mu >= 0):
        raise ValueError(f"mu must be a finite number >= 0, got {mu!r}")
    T, n, m = F.shape
    nu = m - n
    mu_eye = mu * torch.eye(nu, dtype=F.dtype)
    lvec = torch.cat([lx[:T], lu], dim=1)                          # (T, n+nu)
    G = torch.empty(T, nu, n + 1, dtype=F.dtype)                   # [k | K] per step
    Vx, Vxx = lx[T], lxx[T]
    for t in range(T - 1, -1, -1):
        Ft = F[t].T                                                # (n+nu, n), a view
        Q = (Ft @ Vxx) @ F[t]                                      # (n+nu, n+nu)
        Q[:n, :n] += lxx[t]
        Q[n:, n:] += luu[t]
        q = torch.addmv(lvec[t], Ft, Vx)
        Quu, Qux = Q[n:, n:], Q[n:, :n]
        chol, info = torch.linalg.cholesky_ex(Quu + mu_eye)
        if info.item():
            return None
        rhs = torch.cat([q[n:, None], Qux], dim=1)                 # [Qu | Qux]
        if limits is None:
            Gt = torch.cholesky_solve(rhs, chol, out=G[t]).neg_()
        else:
            Gt = _box_step(Quu + mu_eye, rhs, limits[0][t], limits[1][t], out=G[t])
            if Gt is None:
                return None
        k, K = Gt[:, 0], Gt[:, 1:]
        W = torch.addmm(rhs, Quu, Gt)                              # [Quu k + Qu | Quu K + Qux]
        Vx = torch.addmv(torch.addmv(q[:n], K.T, W[:, 0]), Qux.T, k)
        Vxx = torch.addmm(torch.addmm(Q[:n, :n], K.T, W[:, 1:]), Qux.T, K)
        Vxx = 0.5 * (Vxx + Vxx.T)
    return G[:, :, 1:].contiguous(), G[:, :, 0].contiguous()


def _box_step(H: torch.Tensor, rhs: torch.Tensor, lower: np.ndarray, upper: np.ndarray,
              out: torch.Tensor) -> torch.Tensor | None:
    """[k | K] (nu, 1+n) of one step under box limits: k = argmin 0.5 du' H du + Qu' du on
    lower <= du <= upper (``mju_boxQP``), K = -H_ff^-1 Qux_f on the free controls f, 0 on the
    clamped ones. rhs = [Qu | Qux]. None if H is not positive definite."""
    import mujoco

    nu = H.shape[0]
    Hn = np.ascontiguousarray(H.numpy())
    g = np.ascontiguousarray(rhs[:, 0].numpy())
    res, R = np.zeros(nu), np.zeros((nu, nu + 7))
    index = np.zeros(nu, dtype=np.int32)
    rank = mujoco.mju_boxQP(res, R, index, Hn, g, lower, upper)
    if rank < 0:
        return None
    out.zero_()
    out[:, 0] = torch.from_numpy(res)
    free = torch.from_numpy(index[:rank].astype(np.int64))
    if rank:
        Hf = H[free][:, free]
        out[free, 1:] = -torch.linalg.solve(Hf, rhs[free, 1:])
    return out


def _limits(model, U: np.ndarray):
    """(lower, upper) (T, nu) bounds on the control step from the actuators' ctrlrange
    around the controls U (T, nu); unlimited actuators get +-inf."""
    limited = model.actuator_ctrllimited.astype(bool)
    lo = np.where(limited, model.actuator_ctrlrange[:, 0], -np.inf)
    hi = np.where(limited, model.actuator_ctrlrange[:, 1], np.inf)
    return np.ascontiguousarray(lo - U), np.ascontiguousarray(hi - U)


def _controls(controls, nu: int) -> np.ndarray:
    """A (T, nu) C-contiguous float64 control sequence with T >= 1 and finite entries."""
    U = float_array(controls, "controls", (None, nu))
    if len(U) == 0:
        raise ValueError(f"controls must have T >= 1 rows, got shape {U.shape}")
    return U
