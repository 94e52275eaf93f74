"""RolloutService: batched open-loop rollouts and reduced finite-difference derivatives.

Both planners stand on this one object. CEM asks it for the final states of a population of
control sequences in one batched call; iLQR asks it for the nominal trajectory and for the
perturbed one-step transitions of the active DoFs over the whole horizon in one batched call.
Open-loop rollouts run in ``mujoco.batch.Batch`` on ``threads`` threads with the GIL released,
bit-identical to a plain ``mj_step`` loop at any thread count. Derivatives and feedback rollouts
run in the C loops of ``dopt.kernels`` when they were built (derivatives skip the stages a
perturbation leaves unchanged, as ``mjd_transitionFD`` does; feedback needs no Python per step),
else in the same Batch; both routes give the same numbers (tested).
"""

from __future__ import annotations

import logging
import os
import threading
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from mujoco.batch import Batch, SimulationError

from dopt import kernels
from dopt.errors import RolloutError, UnstableRolloutError
from dopt.scene import Scene
from dopt.state import check_states

log = logging.getLogger(__name__)

CTRL = int(mujoco.mjtState.mjSTATE_CTRL)
USER = int(mujoco.mjtState.mjSTATE_USER)
_TIME = int(mujoco.mjtState.mjSTATE_TIME)
_WARNINGS = [n for n in mujoco.mjtWarning.__members__ if n != "mjNWARNING"]


@dataclass(frozen=True)
class RolloutConfig:
    """threads: simulation threads of the batched calls (0: one per CPU core).
    c_kernels: run derivatives and feedback rollouts in dopt.kernels' C loops when they were
    built (False: always mujoco.batch.Batch, the slower reference route)."""

    threads: int = 0
    c_kernels: bool = True

    def __post_init__(self):
        if not isinstance(self.threads, int) or self.threads < 0:
            raise ValueError(f"threads must be an int >= 0, got {self.threads!r}")
        if not isinstance(self.c_kernels, bool):
            raise TypeError(f"c_kernels must be a bool, got {self.c_kernels!r}")


@dataclass(frozen=True)
class FDConfig:
    """Finite differences: step ``eps`` (in each DoF's own unit), forward or centred."""

    eps: float = 1e-6
    centered: bool = False

    def __post_init__(self):
        if not (np.isfinite(self.eps) and self.eps > 0):
            raise ValueError(f"eps must be a positive finite number, got {self.eps!r}")


@dataclass(frozen=True)
class RolloutResult:
    """final_states: (P, ns) state rows after the last step; records: item -> (P, T, ...)
    arrays recorded after each step (MjData field names or mjtState bit specs)."""

    final_states: np.ndarray
    records: dict


@dataclass(frozen=True)
class Trajectory:
    """states: (..., T+1, ns). Row t is the state before step t holding control u_t, so
    rows[:T] feed ``derivatives`` directly; the last row is the final state (holding u_{T-1}).
    controls: (..., T, nu), the controls applied (after clamping, where a call clamps)."""

    states: np.ndarray
    controls: np.ndarray


@dataclass(frozen=True)
class Derivatives:
    """Linearised one-step dynamics on the active DoF set C, for every timestep:

        dx_C[t+1] = A[t] dx_C[t] + B[t] du[t],   dx_C = [dq_C; dv_C]  (tangent space)

    F: (T, 2|C|, 2|C| + nu) = [A B], the one buffer A and B view (the backward pass reads F);
    A: (T, 2|C|, 2|C|), B: (T, 2|C|, nu); dofs: (|C|,) the DoF indices of C (into qvel).
    With C = all DoFs (and na = 0) A and B equal ``mujoco.mjd_transitionFD``.
    """

    F: np.ndarray
    dofs: np.ndarray
    fd: FDConfig

    @property
    def A(self) -> np.ndarray:
        return self.F[:, :, :2 * len(self.dofs)]

    @property
    def B(self) -> np.ndarray:
        return self.F[:, :, 2 * len(self.dofs):]


class RolloutService:
    """Batched rollouts and FD derivatives on one scene.

    Not for concurrent use from several Python threads (calls are serialised by a lock); give
    each thread its own service.
    """

    def __init__(self, scene: Scene, config: RolloutConfig = RolloutConfig()):
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a dopt.Scene, got {type(scene).__name__}")
        self.scene = scene
        self.model = scene.model
        self.config = config
        self.threads = config.threads or os.cpu_count() or 1
        self._batch: Batch | None = None
        self._kernels: kernels.Kernels | None = None
        self._lock = threading.Lock()
        lay = scene.layout
        self._qpos, self._qvel, self._act, self._ctrl = (lay["qpos"], lay["qvel"], lay["act"],
                                                         lay["ctrl"])

    # ------------------------------------------------------------------ rollouts
    def rollout(self, initial_states, controls, *, record: Sequence = (),
                control_spec: int = CTRL) -> RolloutResult:
        """Run P open-loop rollouts of T steps in one batched call.

        Args:
            initial_states: (ns,) or (P, ns) mjSTATE_INTEGRATION rows.
            controls: (P, T, ncontrol) or (T, ncontrol) for every rollout, where ncontrol is
                ``mj_stateSize(model, control_spec)`` (nu for the default spec, ctrl).
            record: MjData field names and/or mjtState specs to record after each step.
            control_spec: mjtState bits within mjSTATE_USER that ``controls`` sets before each
                step (e.g. ctrl | eq_active for a picker that grasps and releases).

        Raises:
            ValueError: bad shapes or dtypes, NaN/inf inputs.
            UnstableRolloutError: a rollout produced NaN or a MuJoCo warning (names which
                rollout and at which step).
        """
        if control_spec & ~USER or not control_spec:
            raise ValueError(f"control_spec must be a non-empty subset of mjSTATE_USER "
                             f"({USER}), got {control_spec}")
        ncontrol = mujoco.mj_stateSize(self.model, control_spec)
        u = _as_float(controls, "controls")
        if u.ndim == 2:
            u = u[None]
        if u.ndim != 3 or u.shape[2] != ncontrol or u.shape[1] == 0:
            raise ValueError(f"controls must have shape (P, T, {ncontrol}) or (T, {ncontrol}) "
                             f"with T >= 1, got {np.shape(controls)}")
        x0 = check_states(self.model, initial_states, name="initial_states")
        n_x0 = x0.shape[0] if x0.ndim == 2 else 1
        if 1 not in (n_x0, u.shape[0]) and n_x0 != u.shape[0]:
            raise ValueError(f"initial_states has {n_x0} rollouts but controls has "
                             f"{u.shape[0]}; give one of them for all or P of each")
        P = max(u.shape[0], n_x0)
        T = u.shape[1]
        items = [_TIME] + [r for r in record if r != _TIME]
        with self._lock:
            batch, ids = self._batch_of(P)
            batch.state[:P] = x0
            batch.warning[:P] = 0
            try:
                rec = batch.rollout(T, control=np.broadcast_to(u, (P, T, ncontrol)),
                                    control_spec=control_spec, record=items, ids=ids)
            except SimulationError as e:
                raise RolloutError(f"rollout: {e}") from e
            final = batch.state[:P].copy()
            self._check_stable(batch, P, final, rec[_TIME][:, :, 0], "rollout")
        if _TIME not in record:
            rec.pop(_TIME)
        return RolloutResult(final, rec)

    def trajectory(self, initial_state, controls) -> Trajectory:
        """One open-loop rollout that keeps every state row: (ns,), (T, nu) -> Trajectory."""
        u = _as_float(controls, "controls")
        if u.ndim != 2:
            raise ValueError(f"controls must have shape (T, nu), got {u.shape}")
        x0 = check_states(self.model, initial_state, batched=False, name="initial_state")
        spec = self.scene.layout.spec
        res = self.rollout(x0, u[None], record=(spec,))
        states = np.concatenate([x0[None], res.records[spec][0]], axis=0)
        states[0, self._ctrl] = u[0]
        states[1:-1, self._ctrl] = u[1:]
        return Trajectory(states, np.array(u))

    def rollout_feedback(self, initial_state, controls, ref_states, gains, dofs) -> Trajectory:
        """P closed-loop rollouts in lock-step: u_t = U[p, t] + K_t dx_C(x_t, ref_t).

        The feedback acts on the tangent deviation of the active DoFs from the reference,
        dx_C = [q_C (-) q_ref_C ; v_C - v_ref_C], as iLQR's forward pass (Eq. 12) needs; the
        dynamics are the full nonlinear model. Controls are clamped to ctrlrange where limited.

        Args:
            initial_state: (ns,) start state of every rollout.
            controls: (P, T, nu) feed-forward controls (e.g. u_bar + alpha_p k for P alphas).
            ref_states: (T, ns) reference rows the deviation is measured from.
            gains: (T, nu, 2|C|) feedback gains on the active set.
            dofs: the active DoF set C (indices, group names).

        Returns:
            Trajectory with states (P, T+1, ns) (row t holds the applied u_t) and the applied
            controls (P, T, nu).
        """
        m = self.model
        x0 = check_states(m, initial_state, batched=False, name="initial_state")
        u = _as_float(controls, "controls")
        ref = check_states(m, ref_states, batched=True, name="ref_states")
        K = _as_float(gains, "gains")
        C = self.scene.as_dofs(dofs)
        P, T = u.shape[:2] if u.ndim == 3 else (0, 0)
        if u.ndim != 3 or u.shape[2] != m.nu or T == 0:
            raise ValueError(f"controls must have shape (P, T, {m.nu}), got {u.shape}")
        if ref.shape[0] != T or K.shape != (T, m.nu, 2 * len(C)):
            raise ValueError(f"ref_states must be ({T}, ns) and gains ({T}, {m.nu}, "
                             f"{2 * len(C)}); got {ref.shape} and {K.shape}")
        lo, hi = self._ctrl_bounds()
        if self.uses_c_kernels:
            with self._lock:
                out, applied, bad = self._kernel().feedback(x0, u, ref, K, C, lo, hi)
            if bad:
                p, step, names = bad[0]
                raise UnstableRolloutError(p, step, names[0], "rollout_feedback")
            return Trajectory(out, applied)
        ref_q, ref_v = ref[:, self._qpos], ref[:, self._qvel][:, C]
        out = np.empty((P, T + 1, self.scene.nstate))
        applied = np.empty((P, T, m.nu))
        diff = self.scene.tangent.difference
        with self._lock:
            batch, ids = self._batch_of(P)
            rows = batch.state
            rows[:P] = x0
            batch.warning[:P] = 0
            try:
                for t in range(T):
                    x = rows[:P]
                    dx = np.concatenate([diff(ref_q[t], x[:, self._qpos], 1.0, C),
                                         x[:, self._qvel][:, C] - ref_v[t]], axis=1)
                    ut = np.clip(u[:, t] + dx @ K[t].T, lo, hi)
                    rows[:P, self._ctrl] = ut
                    applied[:, t] = ut
                    out[:, t] = rows[:P]
                    batch.step(ids=ids)
                    bad = batch.warning[:P, :, 1].any(axis=1) | ~np.isfinite(rows[:P]).all(1)
                    if bad.any():   # lock-step: the first step any rollout went unstable
                        p = int(np.argmax(bad))
                        warned = np.nonzero(batch.warning[p, :, 1])[0]
                        reason = _WARNINGS[warned[0]] if len(warned) else "non-finite state"
                        raise UnstableRolloutError(p, t, reason, "rollout_feedback")
            except SimulationError as e:
                raise RolloutError(f"rollout_feedback: {e}") from e
            out[:, T] = rows[:P]
        return Trajectory(out, applied)

    def _ctrl_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(nu,) lower and upper control bounds (+-inf where not limited)."""
        m = self.model
        limited = m.actuator_ctrllimited.astype(bool)
        return (np.where(limited, m.actuator_ctrlrange[:, 0], -np.inf),
                np.where(limited, m.actuator_ctrlrange[:, 1], np.inf))

    # --------------------------------------------------------------- derivatives
    def derivatives(self, states, dofs=None, fd: FDConfig = FDConfig()) -> Derivatives:
        """Finite-difference A^C, B^C of every state row, for the DoF set C, in one batched call.

        Per timestep this steps the nominal state once plus nu control, |C| velocity and |C|
        position perturbations (twice as many perturbations when centred), not 2*nv + nu.
        Positions of free and ball joints are perturbed in tangent space (mj_integratePos),
        and controls at their ctrlrange limits are differenced one-sidedly inwards, exactly as
        ``mjd_transitionFD``.

        Args:
            states: (T, ns) mjSTATE_INTEGRATION rows, each holding its control u_t (see
                ``Trajectory.states[:-1]``).
            dofs: the active DoF set C: indices into qvel, group names, or None for all DoFs.
            fd: step size and scheme.

        Returns:
            Derivatives with A (T, 2|C|, 2|C|) and B (T, 2|C|, nu).
        """
        m = self.model
        if m.na:
            raise ValueError("derivatives: models with actuator activations (na > 0) are not "
                             "supported; the reduced state holds positions and velocities only")
        if m.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4:
            raise ValueError("derivatives: the RK4 integrator is not supported (as in "
                             "mjd_transitionFD)")
        x = check_states(m, states, batched=True, name="states")
        C = self.scene.dofs() if dofs is None else self.scene.as_dofs(dofs)
        if self.uses_c_kernels:
            lo, hi = self._ctrl_bounds()
            with self._lock:
                F, bad = self._kernel().fd(x, C, fd.eps, fd.centered, lo, hi)
            if bad:
                t, names = bad[0]
                raise UnstableRolloutError(t, 0, names[0], f"derivatives t={t}")
            return Derivatives(F, C, fd)
        T, c, nu, eps = x.shape[0], len(C), m.nu, fd.eps
        sides = (1.0, -1.0) if fd.centered else (1.0,)
        ns = len(sides)
        # row blocks per timestep: nominal | ctrl (ns*nu) | vel (ns*c) | pos (ns*c)
        K = 1 + ns * (nu + 2 * c)
        rows = np.repeat(x[:, None, :], K, axis=1)                    # (T, K, nstate)
        ctrl = x[:, self._ctrl]                                        # (T, nu)
        # controls: which one-sided nudges stay inside ctrlrange (as mjd_transitionFD)
        limited = m.actuator_ctrllimited.astype(bool)
        lo, hi = m.actuator_ctrlrange[:, 0], m.actuator_ctrlrange[:, 1]

        def inside(a, b):
            return ~limited | ((a >= lo) & (a <= hi) & (b >= lo) & (b <= hi))

        fwd_ok = inside(ctrl, ctrl + eps)                              # (T, nu)
        back_ok = (fd.centered | ~fwd_ok) & inside(ctrl - eps, ctrl)
        col = self._ctrl.start + np.arange(nu)
        r = 1
        if fd.centered:
            rows[:, r + np.arange(nu), col] += eps
            rows[:, r + nu + np.arange(nu), col] -= eps
        else:  # one row per control: forward if allowed, else backward, else unused
            rows[:, r + np.arange(nu), col] += np.where(fwd_ok, eps, np.where(back_ok, -eps, 0))
        r += ns * nu
        vel_rows = r + np.arange(ns * c)
        vcol = self._qvel.start + np.tile(C, ns)
        rows[:, vel_rows, vcol] += np.repeat(np.array(sides) * eps, c)
        r += ns * c
        pos_rows = r + np.arange(ns * c)
        for k, side in enumerate(sides):
            block = rows[:, pos_rows[k * c:(k + 1) * c], self._qpos]   # (T, c, nq)
            flat = self.scene.tangent.perturb(block.reshape(-1, m.nq), np.tile(C, T), side * eps)
            rows[:, pos_rows[k * c:(k + 1) * c], self._qpos] = flat.reshape(T, c, m.nq)

        with self._lock:
            batch, ids = self._batch_of(T * K)
            n = T * K
            batch.state[:n] = rows.reshape(n, -1)
            batch.warning[:n] = 0
            try:
                batch.step(ids=ids)
            except SimulationError as e:
                raise RolloutError(f"derivatives: {e}") from e
            nxt = batch.state[:n].reshape(T, K, -1).copy()
            self._check_stable(batch, n, nxt.reshape(n, -1), None, "derivatives",
                               rows_per_t=K)

        qpos, qvel = nxt[..., self._qpos], nxt[..., self._qvel]       # (T, K, nq|nv)
        diff = self.scene.tangent.difference

        def dstate(a, b, h):
            """(T, k, .) next states a -> b, tangent difference on C: (T, k, 2c)."""
            dq = diff(qpos[:, a], qpos[:, b], h, C)
            dv = (1.0 / h) * (qvel[:, b][..., C] - qvel[:, a][..., C])
            return np.concatenate([dq, dv], axis=-1)

        nom = np.zeros(nu, int)
        if fd.centered:
            plus, minus = 1 + np.arange(nu), 1 + nu + np.arange(nu)
            both = dstate(minus, plus, 2 * eps)
            fwd_only = dstate(nom, plus, eps)
            back_only = dstate(minus, nom, eps)
            f, b_ = fwd_ok[..., None], back_ok[..., None]
            Bt = np.where(f & b_, both, np.where(f, fwd_only, np.where(b_, back_only, 0.0)))
        else:
            pert = 1 + np.arange(nu)
            Bt = np.where(fwd_ok[..., None], dstate(nom, pert, eps),
                          np.where(back_ok[..., None], dstate(pert, nom, eps), 0.0))
        cols = []
        for block in (vel_rows, pos_rows):
            if fd.centered:
                cols.append(dstate(block[c:], block[:c], 2 * eps))
            else:
                cols.append(dstate(np.zeros(c, int), block, eps))
        # perturbation blocks (T, k, 2c) -> columns of F = [A B]: [dq_C, dv_C | u]
        Ft = np.concatenate([cols[1], cols[0], Bt], axis=1)
        return Derivatives(np.ascontiguousarray(Ft.transpose(0, 2, 1)), C, fd)

    # ------------------------------------------------------------------ helpers
    @property
    def uses_c_kernels(self) -> bool:
        """Whether derivatives and feedback rollouts run in dopt.kernels' C loops."""
        return self.config.c_kernels and kernels.load() is not None

    def _kernel(self) -> kernels.Kernels:
        if self._kernels is None:
            self._kernels = kernels.Kernels(self.model, self.scene.layout, self.threads)
        return self._kernels

    def _batch_of(self, n: int) -> tuple[Batch, np.ndarray | None]:
        """A batch with at least n simulations (grown geometrically) and the ids of the first n."""
        if self._batch is None or self._batch.nsim < n:
            size = n if self._batch is None else max(n, 2 * self._batch.nsim)
            log.debug("allocating a batch of %d simulations on %d threads", size, self.threads)
            self._batch = Batch(self.model, size, nthread=self.threads)
        ids = None if self._batch.nsim == n else np.arange(n, dtype=np.int32)
        return self._batch, ids

    def _check_stable(self, batch: Batch, n: int, final: np.ndarray, times, what: str,
                      rows_per_t: int | None = None) -> None:
        warned = batch.warning[:n, :, 1] > 0                             # (n, nwarning)
        bad = warned.any(axis=1) | ~np.isfinite(final).all(axis=1)
        if not bad.any():
            return
        i = int(np.argmax(bad))
        reason = (_WARNINGS[int(np.argmax(warned[i]))] if warned[i].any()
                  else "non-finite state")
        if rows_per_t is not None:  # derivatives: row i is timestep i // K, perturbation i % K
            what = f"derivatives t={i // rows_per_t} perturbation={i % rows_per_t}"
            step = 0
        else:
            t = times[i]
            stalled = np.nonzero(np.diff(t) <= 0)[0]
            step = int(stalled[0] + 1) if len(stalled) else len(t) - 1
        raise UnstableRolloutError(i, step, reason, what)


def _as_float(x, name: str) -> np.ndarray:
    arr = np.asarray(x)
    if not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"{name} must be a float array, got dtype {arr.dtype}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN/inf")
    return np.ascontiguousarray(arr, dtype=np.float64)
