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
from dopt.stability import Stability
from dopt.state import StateLayout, fault, faulty_rows

log = logging.getLogger(__name__)

CTRL = int(mujoco.mjtState.mjSTATE_CTRL)

#: largest bytes of MjData fields recorded by one Batch.rollout call of an open-loop rollout
CHUNK_BYTES = 32 << 20


def ctrl_bounds(model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """(nu,) lower and upper control bounds (+-inf where not limited)."""
    limited = model.actuator_ctrllimited.astype(bool)
    return (np.where(limited, model.actuator_ctrlrange[:, 0], -np.inf),
            np.where(limited, model.actuator_ctrlrange[:, 1], np.inf))


def _missing(dtype: np.dtype):
    """What a record holds for steps a simulation never took: NaN, or 0 for integer items."""
    return np.nan if np.issubdtype(dtype, np.floating) else 0


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
    return i, why_unstable(batch, i, states[i], layout)


def why_unstable(batch: Batch, i: int, state: np.ndarray, layout: StateLayout) -> str:
    """Why simulation i of the batch, now in ``state`` (ns,), is unstable: its first MuJoCo
    warning's name, else the state's fault (``state.fault``)."""
    names = warning_names(batch.warning[i, :, 1])
    return names[0] if names else (fault(layout, state) or "non-finite state")


class BatchRoute:
    """Rollouts and derivatives on one scene in a ``mujoco.batch.Batch`` of ``threads``
    threads, allocated on first use and grown geometrically."""

    def __init__(self, scene: Scene, threads: int):
        self.scene = scene
        self.model = scene.model
        self.threads = threads
        self.lo, self.hi = ctrl_bounds(scene.model)                     # (nu,) each
        self._batch: Batch | None = None
        self._scratch: mujoco.MjData | None = None
        lay = scene.layout
        self._qpos, self._qvel, self._ctrl = lay["qpos"], lay["qvel"], lay["ctrl"]

    def close(self) -> None:
        """Drop the Batch (its simulations and threads go with it)."""
        self._batch = None

    # ------------------------------------------------------------------ rollouts
    def rollout(self, x0: np.ndarray, u: np.ndarray, control_spec: int,
                record, lengths: np.ndarray) -> tuple[np.ndarray, dict, Stability]:
        """P open-loop rollouts of up to T steps: x0 (ns,) or (P, ns) or (1, ns), u (P, T,
        ncontrol), lengths (P,) the steps each takes (in [1, T]).

        Runs in chunks of steps so that the fields the stability monitor reads are checked
        after every step without holding all T of them; a chunk ends at every rollout's own
        length, where that rollout leaves the batch. Every rollout runs its steps (a broken
        bound is only flagged) unless MuJoCo warns or raises, where it stops; a rollout that
        stopped or ended repeats its last record (NaN, or 0 for integer items, where it has
        none); results do not depend on the chunk length nor on the other rollouts.

        Returns (final states (P, ns), records: item -> (P, T, ...), the verdict)."""
        P, T = u.shape[:2]
        mon = self.scene.monitor
        batch, _ = self._batch_of(P)
        batch.state[:P] = x0
        batch.warning[:P] = 0
        scan = mon.start(P)
        items = list(dict.fromkeys(list(record) + list(mon.record)))
        K = self._chunk(P, T, items)
        rec = {item: self._record(item, P, T) for item in record}
        active = np.arange(P, dtype=np.int32)
        s = 0
        for stop in np.union1d(np.arange(K, lengths.max(), K), lengths):
            k = int(stop) - s
            out, raised = self._chunk_rollout(batch, active, k, u[:, s:s + k], control_spec,
                                              items)
            for i, why in raised.items():        # MuJoCo raised: flagged, stopped at its state
                start = x0 if x0.ndim == 1 else x0[i if len(x0) > 1 else 0]   # before the chunk
                step, reason = self._replay(start, u[i, :s + k], control_spec) or \
                    (s, f"MuJoCo error: {why}")
                scan.flag(i, step, reason)
            if raised:
                stopped = np.array(sorted(raised))
                active = active[~np.isin(active, stopped)]
                rows = stopped if len(active) else slice(None)    # none left: all rows stop
                for item in record:
                    rec[item][rows, s:] = rec[item][rows, s - 1:s] if s else \
                        _missing(rec[item].dtype)
                if not len(active):
                    break
            for item in record:
                rec[item][active, s:s + k] = out[item]
                if len(active) < P and s:     # stopped rollouts repeat their last record
                    stopped = np.setdiff1d(np.arange(P), active)
                    rec[item][stopped, s:s + k] = rec[item][stopped, s - 1:s]
            scan.update(active, s, {f: out[f] for f in mon.record})
            s += k
            # Batch stops a warned simulation: so here; an ended one leaves the batch
            active = active[~(batch.warning[active, :, 1] > 0).any(axis=1)
                            & (lengths[active] > s)]
            if not len(active):
                for item in record:
                    rec[item][:, s:] = rec[item][:, s - 1:s]
                break
        final = batch.state[:P].copy()
        warned = (batch.warning[:P, :, 1] > 0).any(axis=1) | faulty_rows(self.scene.layout,
                                                                          final)
        for i in np.flatnonzero(warned):
            start = x0 if x0.ndim == 1 else x0[i if len(x0) > 1 else 0]
            fallback = why_unstable(batch, i, final[i], self.scene.layout)
            step, reason = (self._replay(start, u[i, :lengths[i]], control_spec)
                            or (int(lengths[i]) - 1, fallback))
            scan.flag(int(i), step, reason)
        return final, rec, scan.result()

    def _chunk_rollout(self, batch: Batch, active: np.ndarray, k: int, u: np.ndarray,
                       control_spec: int, items: list) -> tuple[dict, dict[int, str]]:
        """k steps of the simulations ``active`` (n,) under controls u (P, k, ncontrol).

        Where MuJoCo raises in some of them (e.g. an exploding sheet's contacts overflow the
        arena), ``Batch.rollout`` leaves those at their state before the call and loses the
        call's records: the chunk is run again from the saved states without them. Returns
        (records of the simulations still active: item -> (n', k, ...), {simulation: MuJoCo's
        message} of those that raised)."""
        raised: dict[int, str] = {}
        state, warning = batch.state[active].copy(), batch.warning[active].copy()
        while True:
            run = active[~np.isin(active, list(raised))]
            if not len(run):
                return {item: None for item in items}, raised
            try:
                return batch.rollout(k, control=np.ascontiguousarray(u[run]),
                                     control_spec=control_spec, record=items,
                                     ids=run if len(run) < batch.nsim else None), raised
            except SimulationError as e:
                for i in e.ids:
                    raised[int(i)] = batch.error(int(i))
                log.warning("rollout: MuJoCo raised in simulations %s (%s); flagged unstable",
                            list(map(int, e.ids)), raised[int(e.ids[0])])
                batch.state[active], batch.warning[active] = state, warning

    def _record(self, item, P: int, T: int) -> np.ndarray:
        """An empty record (P, T, ...) of one ``Batch.rollout`` item (a field name or a state
        spec)."""
        if isinstance(item, str):
            field = np.asarray(getattr(self._data(), item))
            return np.empty((P, T) + field.shape, field.dtype)
        return np.empty((P, T, mujoco.mj_stateSize(self.model, int(item))))

    def _chunk(self, P: int, T: int, items: list) -> int:
        """Steps per Batch.rollout call so that the records of one call stay under
        CHUNK_BYTES."""
        data = self._data()
        row = sum(np.asarray(getattr(data, f)).nbytes if isinstance(f, str)
                  else 8 * mujoco.mj_stateSize(self.model, int(f)) for f in items)
        return int(np.clip(CHUNK_BYTES // max(1, P * row), 1, T))

    def _data(self) -> mujoco.MjData:
        if self._scratch is None:
            self._scratch = mujoco.MjData(self.model)
        return self._scratch

    def _replay(self, x0: np.ndarray, u: np.ndarray, control_spec: int) -> tuple[int, str] | None:
        """(step, reason) of the first step of one open-loop rollout, x0 (ns,), u (T,
        ncontrol), that warns or leaves no valid state, replayed with mj_step (which
        ``Batch.rollout`` equals bit for bit; it stops a simulation at its first warning, which
        can come a step after the step that caused it); None if none does."""
        m, lay = self.model, self.scene.layout
        d = mujoco.MjData(m)
        row, t = np.empty(lay.size), 0
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
        except mujoco.FatalError as e:   # MuJoCo raised at step t (as the batch did)
            return t, f"MuJoCo error: {e}"
        except Exception:  # the replay itself failed: the batch's report stands
            log.debug("replay of an unstable rollout failed", exc_info=True)
        return None

    def feedback(self, x0: np.ndarray, u: np.ndarray, ref: np.ndarray, K: np.ndarray,
                 C: np.ndarray) -> tuple[np.ndarray, np.ndarray, Stability]:
        """P closed-loop rollouts in lock-step: x0 (ns,), u (P, T, nu) feed-forward, ref
        (T, ns), K (T, nu, 2|C|), C (|C|,); u_t = clip(u[p, t] + K_t dx_C(x_t, ref_t)).

        A rollout that warns, leaves a bad state or breaks a bound at step t is not stepped
        further: its rows after t + 1 repeat row t + 1, its later controls repeat u_t. One in
        which MuJoCo raises during step t (e.g. its contacts overflow the arena) is flagged
        with MuJoCo's message and holds row t; the others go on as if it were not there.

        Returns (states (P, T+1, ns), applied controls (P, T, nu), the verdict)."""
        P, T, nu = u.shape
        ref_q, ref_v = ref[:, self._qpos], ref[:, self._qvel][:, C]
        out = np.empty((P, T + 1, self.scene.nstate))
        applied = np.empty((P, T, nu))
        diff = self.scene.tangent.difference
        mon, lay = self.scene.monitor, self.scene.layout
        scan = mon.start(P)
        batch, _ = self._batch_of(P)
        rows = batch.state
        rows[:P] = x0
        batch.warning[:P] = 0
        active = np.arange(P, dtype=np.int32)
        step_u = np.zeros((P, 1, nu))
        for t in range(T):
            x = rows[active]
            dx = np.concatenate([diff(ref_q[t], x[:, self._qpos], 1.0, C),
                                 x[:, self._qvel][:, C] - ref_v[t]], axis=1)
            # K_t dx row by row (a product, then a sum over each row's own axis): a row's
            # control must not depend on how many rows share the batch, and matmul and
            # einsum round by the batch's shape (they vectorise across rows)
            ut = np.clip(u[active, t] + (dx[:, None, :] * K[t]).sum(axis=2),
                         self.lo, self.hi)
            x[:, self._ctrl] = ut
            rows[active] = x
            applied[active, t] = ut
            out[active, t] = x
            step_u[active, 0] = ut
            # one-step rollout: the step, and the fields the monitor reads (a
            # non-persistent Batch keeps no MjData fields between calls)
            rec, raised = self._chunk_rollout(batch, active, 1, step_u, CTRL, list(mon.record))
            for i, why in raised.items():      # MuJoCo raised: stopped before the step
                scan.flag(i, t, f"MuJoCo error: {why}")
                out[i, t + 1:] = out[i, t]
                applied[i, t + 1:] = applied[i, t]
            if raised:
                active = active[~np.isin(active, list(raised))]
                if not len(active):
                    break
            nxt = rows[active]
            out[active, t + 1] = nxt
            warned = (batch.warning[active, :, 1] > 0).any(axis=1)
            bad = warned | faulty_rows(lay, nxt)
            for j in np.flatnonzero(bad):
                scan.flag(int(active[j]), t, why_unstable(batch, active[j], nxt[j], lay))
            ok = active[~bad]
            scan.update(ok, t, {f: rec[f][~bad] for f in mon.record})
            stopped = active[scan.unstable[active]]
            if len(stopped):
                out[stopped, t + 2:] = out[stopped, t + 1:t + 2]
                applied[stopped, t + 1:] = applied[stopped, t:t + 1]
                active = active[~scan.unstable[active]]
                if not len(active):
                    break
        return out, applied, scan.result()

    # --------------------------------------------------------------- derivatives
    def derivatives(self, x: np.ndarray, C: np.ndarray, eps: float,
                    centered: bool) -> np.ndarray:
        """F = [A B] (T, 2|C|, 2|C| + nu) of the state rows x (T, ns) on the DoF set C (|C|,).

        All perturbed rows of all timesteps go through one ``Batch.step``: per timestep the
        nominal row, then nu control, |C| velocity and |C| position perturbations (each block
        twice when centred, + then -)."""
        rows, fwd_ok, back_ok, vel_rows, pos_rows = self._fd_rows(x, C, eps, centered)
        nxt = self._fd_step(rows)
        return self._fd_jacobian(nxt, C, eps, centered, fwd_ok, back_ok, vel_rows, pos_rows)

    def _fd_rows(self, x: np.ndarray, C: np.ndarray, eps: float, centered: bool):
        """The perturbed rows of ``derivatives``: (rows (T, K, ns), fwd_ok, back_ok (T, nu):
        which one-sided control nudges stay inside ctrlrange, vel_rows, pos_rows: the indices
        of the velocity and position blocks among the K rows of a timestep)."""
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
        return rows, fwd_ok, back_ok, vel_rows, pos_rows

    def _fd_step(self, rows: np.ndarray) -> np.ndarray:
        """The next states (T, K, ns) of the perturbed rows (T, K, ns), all in one
        ``Batch.step``; an unstable row raises ``UnstableRolloutError`` (rollout: its
        perturbation k, step: its timestep t)."""
        T, K = rows.shape[:2]
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
        return nxt

    def _fd_jacobian(self, nxt: np.ndarray, C: np.ndarray, eps: float, centered: bool,
                     fwd_ok: np.ndarray, back_ok: np.ndarray, vel_rows: np.ndarray,
                     pos_rows: np.ndarray) -> np.ndarray:
        """F = [A B] (T, 2|C|, 2|C| + nu) from the next states ``nxt`` (T, K, ns) of the rows
        ``_fd_rows`` built: finite differences on the tangent of C, control columns one-sided
        where the other side leaves ctrlrange (zero where neither fits)."""
        c, nu = len(C), self.model.nu
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
