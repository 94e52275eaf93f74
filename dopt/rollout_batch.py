"""The mujoco.batch.Batch route of RolloutService: open-loop rollouts, lock-stepped feedback
rollouts and reduced FD derivatives, all on one ``Batch`` of simulations.

Open-loop rollouts run in ``Batch.rollout`` on ``threads`` threads with the GIL released,
bit-identical to a plain ``mj_step`` loop at any thread count. Feedback rollouts step all P
rollouts together (``Batch.step``), computing the feedback in numpy between steps;
derivatives build every perturbed state row of every timestep and step them in one
``Batch.step``. The C-kernel route (``dopt.rollout_c``) inherits the open-loop rollouts and
replaces the other two.

Inputs arrive validated by ``dopt.rollout.RolloutService``; the route returns plain arrays,
which the service wraps in its result types. Not for concurrent use (the service serialises
calls).
"""

from __future__ import annotations

import logging

import mujoco
import numpy as np
from mujoco.batch import Batch, SimulationError

from dopt.errors import RolloutError, UnstableRolloutError
from dopt.kernels import warning_names
from dopt.scene import Scene
from dopt.state import StateLayout, fault, faulty_rows

log = logging.getLogger(__name__)


def ctrl_bounds(model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """(nu,) lower and upper control bounds (+-inf where not limited)."""
    limited = model.actuator_ctrllimited.astype(bool)
    return (np.where(limited, model.actuator_ctrlrange[:, 0], -np.inf),
            np.where(limited, model.actuator_ctrlrange[:, 1], np.inf))


def first_unstable(batch: Batch, n: int, states: np.ndarray,
                   layout: StateLayout) -> tuple[int, str] | None:
    """(i, reason) of the first of the batch's first n simulations that raised a MuJoCo
    warning or holds a row of ``states`` (n, ns) that is no valid state (``state.fault``);
    None if none did. reason: the first warning's name, else the fault."""
    warned = batch.warning[:n, :, 1] > 0                                 # (n, nwarning)
    bad = warned.any(axis=1) | faulty_rows(layout, states)
    if not bad.any():
        return None
    i = int(np.argmax(bad))
    names = warning_names(batch.warning[i, :, 1])
    return i, names[0] if names else (fault(layout, states[i]) or "non-finite state")


class BatchRoute:
    """Rollouts and derivatives on one scene in a ``mujoco.batch.Batch`` of ``threads``
    threads, allocated on first use and grown geometrically."""

    def __init__(self, scene: Scene, threads: int):
        self.scene = scene
        self.model = scene.model
        self.threads = threads
        self.lo, self.hi = ctrl_bounds(scene.model)                     # (nu,) each
        self._batch: Batch | None = None
        lay = scene.layout
        self._qpos, self._qvel, self._ctrl = lay["qpos"], lay["qvel"], lay["ctrl"]

    def close(self) -> None:
        """Drop the Batch (its simulations and threads go with it)."""
        self._batch = None

    # ------------------------------------------------------------------ rollouts
    def rollout(self, x0: np.ndarray, u: np.ndarray, control_spec: int,
                record) -> tuple[np.ndarray, dict]:
        """P open-loop rollouts of T steps: x0 (ns,) or (P, ns) or (1, ns), u (P, T, ncontrol).

        Returns (final states (P, ns), records: item -> (P, T, ...))."""
        P, T = u.shape[:2]
        batch, ids = self._batch_of(P)
        batch.state[:P] = x0
        batch.warning[:P] = 0
        try:
            rec = batch.rollout(T, control=u, control_spec=control_spec, record=list(record),
                                ids=ids)
        except SimulationError as e:
            raise RolloutError(f"rollout: {e}") from e
        final = batch.state[:P].copy()
        if bad := first_unstable(batch, P, final, self.scene.layout):
            i, reason = bad
            start = x0 if x0.ndim == 1 else x0[i if len(x0) > 1 else 0]
            step, reason = self._replay(start, u[i], control_spec) or (T - 1, reason)
            raise UnstableRolloutError(i, step, reason, "rollout")
        return final, rec

    def _replay(self, x0: np.ndarray, u: np.ndarray, control_spec: int) -> tuple[int, str] | None:
        """(step, reason) of the first step of one open-loop rollout, x0 (ns,), u (T,
        ncontrol), that warns or leaves no valid state, replayed with mj_step (which
        ``Batch.rollout`` equals bit for bit; it stops a simulation at its first warning, which
        can come a step after the step that caused it); None if none does."""
        m, lay = self.model, self.scene.layout
        d = mujoco.MjData(m)
        row = np.empty(lay.size)
        try:
            mujoco.mj_setState(m, d, x0, lay.spec)
            for t, ut in enumerate(u):
                mujoco.mj_setState(m, d, np.ascontiguousarray(ut), control_spec)
                mujoco.mj_step(m, d)
                if names := warning_names(d.warning.number):
                    return t, names[0]
                mujoco.mj_getState(m, d, row, lay.spec)
                if reason := fault(lay, row):
                    return t, reason
        except Exception:  # a MuJoCo error in the replay: the batch's report stands
            log.debug("replay of an unstable rollout failed", exc_info=True)
        return None

    def feedback(self, x0: np.ndarray, u: np.ndarray, ref: np.ndarray, K: np.ndarray,
                 C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """P closed-loop rollouts in lock-step: x0 (ns,), u (P, T, nu) feed-forward, ref
        (T, ns), K (T, nu, 2|C|), C (|C|,); u_t = clip(u[p, t] + K_t dx_C(x_t, ref_t)).

        Returns (states (P, T+1, ns), applied controls (P, T, nu))."""
        P, T, nu = u.shape
        ref_q, ref_v = ref[:, self._qpos], ref[:, self._qvel][:, C]
        out = np.empty((P, T + 1, self.scene.nstate))
        applied = np.empty((P, T, nu))
        diff = self.scene.tangent.difference
        batch, ids = self._batch_of(P)
        rows = batch.state
        rows[:P] = x0
        batch.warning[:P] = 0
        try:
            for t in range(T):
                x = rows[:P]
                dx = np.concatenate([diff(ref_q[t], x[:, self._qpos], 1.0, C),
                                     x[:, self._qvel][:, C] - ref_v[t]], axis=1)
                ut = np.clip(u[:, t] + dx @ K[t].T, self.lo, self.hi)
                rows[:P, self._ctrl] = ut
                applied[:, t] = ut
                out[:, t] = rows[:P]
                batch.step(ids=ids)
                # lock-step: the first step that failed, its first rollout
                if bad := first_unstable(batch, P, rows[:P], self.scene.layout):
                    raise UnstableRolloutError(bad[0], t, bad[1], "rollout_feedback")
        except SimulationError as e:
            raise RolloutError(f"rollout_feedback: {e}") from e
        out[:, T] = rows[:P]
        return out, applied

    # --------------------------------------------------------------- derivatives
    def derivatives(self, x: np.ndarray, C: np.ndarray, eps: float,
                    centered: bool) -> np.ndarray:
        """F = [A B] (T, 2|C|, 2|C| + nu) of the state rows x (T, ns) on the DoF set C (|C|,).

        All perturbed rows of all timesteps go through one ``Batch.step``: per timestep the
        nominal row, then nu control, |C| velocity and |C| position perturbations (each block
        twice when centred, + then -)."""
        m = self.model
        T, c, nu = x.shape[0], len(C), m.nu
        sides = (1.0, -1.0) if centered else (1.0,)
        ns = len(sides)
        # row blocks per timestep: nominal | ctrl (ns*nu) | vel (ns*c) | pos (ns*c)
        K = 1 + ns * (nu + 2 * c)
        rows = np.repeat(x[:, None, :], K, axis=1)                    # (T, K, nstate)
        ctrl = x[:, self._ctrl]                                        # (T, nu)

        def inside(a, b):   # controls: the one-sided nudges that stay inside ctrlrange
            return (a >= self.lo) & (a <= self.hi) & (b >= self.lo) & (b <= self.hi)

        fwd_ok = inside(ctrl, ctrl + eps)                              # (T, nu)
        back_ok = (centered | ~fwd_ok) & inside(ctrl - eps, ctrl)
        col = self._ctrl.start + np.arange(nu)
        r = 1
        if centered:
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

        batch, ids = self._batch_of(T * K)
        n = T * K
        batch.state[:n] = rows.reshape(n, -1)
        batch.warning[:n] = 0
        try:
            batch.step(ids=ids)
        except SimulationError as e:
            raise RolloutError(f"derivatives: {e}") from e
        nxt = batch.state[:n].reshape(T, K, -1).copy()
        if bad := first_unstable(batch, n, nxt.reshape(n, -1), self.scene.layout):
            t, k = divmod(bad[0], K)                        # row i: timestep i // K
            raise UnstableRolloutError(k, t, bad[1], f"derivatives t={t} perturbation={k}")

        qpos, qvel = nxt[..., self._qpos], nxt[..., self._qvel]       # (T, K, nq|nv)
        diff = self.scene.tangent.difference

        def dstate(a, b, h):
            """(T, k, .) next states a -> b, tangent difference on C: (T, k, 2c)."""
            dq = diff(qpos[:, a], qpos[:, b], h, C)
            dv = (1.0 / h) * (qvel[:, b][..., C] - qvel[:, a][..., C])
            return np.concatenate([dq, dv], axis=-1)

        nom = np.zeros(nu, int)
        if centered:
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
            if centered:
                cols.append(dstate(block[c:], block[:c], 2 * eps))
            else:
                cols.append(dstate(np.zeros(c, int), block, eps))
        # perturbation blocks (T, k, 2c) -> columns of F = [A B]: [dq_C, dv_C | u]
        Ft = np.concatenate([cols[1], cols[0], Bt], axis=1)
        return np.ascontiguousarray(Ft.transpose(0, 2, 1))

    # ------------------------------------------------------------------ helpers
    def _batch_of(self, n: int) -> tuple[Batch, np.ndarray | None]:
        """A batch with at least n simulations (grown geometrically) and the ids of the first n."""
        if self._batch is None or self._batch.nsim < n:
            size = n if self._batch is None else max(n, 2 * self._batch.nsim)
            log.debug("allocating a batch of %d simulations on %d threads", size, self.threads)
            self._batch = Batch(self.model, size, nthread=self.threads)
        ids = None if self._batch.nsim == n else np.arange(n, dtype=np.int32)
        return self._batch, ids
