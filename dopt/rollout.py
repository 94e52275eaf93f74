"""RolloutService: batched open-loop rollouts and reduced finite-difference derivatives.

Both planners stand on this one object. CEM asks it for the final states of a population of
control sequences in one batched call; iLQR asks it for the nominal trajectory and for the
perturbed one-step transitions of the active DoFs over the whole horizon in one batched call.

This module holds the public face: configs, result types and the ``RolloutService`` facade,
which validates inputs and delegates to one of two routes, chosen once at construction:

- ``dopt.rollout_c.CRoute`` (the default where ``dopt.kernels`` was built): derivatives and
  feedback rollouts in C loops (derivatives skip the stages a perturbation leaves unchanged,
  as ``mjd_transitionFD`` does; feedback needs no Python per step);
- ``dopt.rollout_batch.BatchRoute``: everything in ``mujoco.batch.Batch``.

Open-loop rollouts run in ``mujoco.batch.Batch`` on both routes, on ``threads`` threads with
the GIL released, bit-identical to a plain ``mj_step`` loop at any thread count. Both routes
give the same numbers (tested).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Sequence
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from dopt import kernels
from dopt.errors import UnstableRolloutError
from dopt.rollout_batch import BatchRoute
from dopt.rollout_c import CRoute
from dopt.scene import Scene
from dopt.stability import Monitor, Stability
from dopt.state import MAXVAL, check_spec, check_states, fault
from dopt.validation import check_config, check_int, float_array, index_array, is_int

CTRL = int(mujoco.mjtState.mjSTATE_CTRL)
USER = int(mujoco.mjtState.mjSTATE_USER)


@dataclass(frozen=True)
class RolloutConfig:
    """threads: simulation threads of the batched calls (0: one per CPU core).
    c_kernels: run derivatives and feedback rollouts in dopt.kernels' C loops when they were
    built (False: always mujoco.batch.Batch, the slower reference route).
    on_unstable: what a rollout that breaks the scene's stability bounds (or makes MuJoCo
    warn, or goes non-finite) does: "flag" it in the result's ``stability`` verdict and let the
    others finish, or "raise" ``UnstableRolloutError`` naming the first one."""

    threads: int = 0
    c_kernels: bool = True
    on_unstable: str = "flag"

    def __post_init__(self):
        check_config(self, minimum={"threads": 0}, choices={"on_unstable": ("flag", "raise")})


def share_cores(concurrent: int, cores: int | None = None) -> int:
    """``RolloutConfig.threads`` for each of ``concurrent`` rollout services that run at once
    (a sweep's trials in parallel workers): 0, every core, for one; else the ``cores``
    (default: those this process may use) shared out, at least one thread each. A batch's
    results do not depend on its threads (``mujoco.batch.Batch``: bit-identical at any
    count), so a single trial takes every core and a sweep of as many trials as cores keeps
    one thread per trial."""
    concurrent = check_int(concurrent, "concurrent", minimum=1)
    cores = available_cores() if cores is None else check_int(cores, "cores", minimum=1)
    return 0 if concurrent == 1 else max(1, cores // concurrent)


def available_cores() -> int:
    """The cores this process may run on (its affinity, else the machine's)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:                       # no affinity on this platform
        return os.cpu_count() or 1


@dataclass(frozen=True)
class FDConfig:
    """Finite differences: step ``eps`` (in each DoF's own unit), forward or centred.

    The default, forward with eps 1e-3, is what the planners use. The authors used centred
    differences with eps 1e-6, but at 1e-6 the tilt DoFs of cylinders standing on a table give
    A entries ~1/eps (contact switching), which swamp iLQR's gains K and put untouched
    distractors at the top of the importance ranking (measured on clutter: |A|max 6e5 at
    1e-6, 2e3 at 1e-3; pinned by tests/planners/test_importance_clutter.py). Forward also
    takes half the steps. Comparisons against ``mujoco.mjd_transitionFD`` pass their eps
    (1e-6) explicitly.
    """

    eps: float = 1e-3
    centered: bool = False

    def __post_init__(self):
        check_config(self, positive=("eps",))
        if self.eps < MIN_FD_EPS:
            raise ValueError(f"FDConfig.eps must be >= {MIN_FD_EPS:g}: a step of {self.eps:g} "
                             f"cannot move a state entry of magnitude 1 in double precision "
                             f"(derivatives would come out exactly 0)")


#: the smallest finite-difference step: 1e4 units in the last place of a state entry of
#: magnitude 1 (float64 resolves 2.2e-16 there), so that x + eps - x keeps 4 digits
MIN_FD_EPS = 1e4 * float(np.finfo(float).eps)


def check_fd_step(eps: float, states: np.ndarray, scene: Scene, dofs: np.ndarray) -> None:
    """ValueError if ``eps`` cannot move the largest position or velocity entry of the
    perturbed DoFs ``dofs`` in ``states`` (P, ns) by 1e4 units in its last place: their
    finite differences would be rounding noise or exactly 0. Entries beyond MuJoCo's limit
    (``dopt.state.MAXVAL``) are left to the stability verdict."""
    m, layout = scene.model, scene.layout
    joints = np.unique(m.dof_jntid[dofs])
    width = {int(mujoco.mjtJoint.mjJNT_FREE): 7, int(mujoco.mjtJoint.mjJNT_BALL): 4}
    qpos = np.concatenate([m.jnt_qposadr[j] + np.arange(width.get(int(m.jnt_type[j]), 1))
                           for j in joints]) if len(joints) else np.zeros(0, int)
    q = np.abs(np.concatenate([states[:, layout["qpos"].start + qpos],
                               states[:, layout["qvel"].start + np.asarray(dofs)]], axis=1))
    scale = max(float(q[q <= MAXVAL].max(initial=0.0)), 1.0)
    if eps < MIN_FD_EPS * scale:
        raise ValueError(f"fd.eps {eps:g} is too small for states of magnitude {scale:.3g}: "
                         f"it must be >= {MIN_FD_EPS * scale:.3g} to move them in double "
                         f"precision")


@dataclass(frozen=True)
class RolloutResult:
    """final_states: (P, ns) state rows after the last step (a rollout that made MuJoCo warn:
    where MuJoCo stopped it); records: item -> (P, T, ...) arrays recorded after each step
    (MjData field names or mjtState bit specs); stability: the verdict on each rollout
    (``dopt.stability.Stability``)."""

    final_states: np.ndarray
    records: dict
    stability: Stability


@dataclass(frozen=True)
class Trajectory:
    """states: (..., T+1, ns). Row t is the state before step t holding control u_t, so
    rows[:T] feed ``derivatives`` directly; the last row is the final state (holding u_{T-1}).
    controls: (..., T, nu), the controls applied (after clamping, where a call clamps).
    stability: the verdict on each rollout (P of them, or one for ``trajectory``); rows after
    an unstable rollout's failing step repeat the state it stopped in."""

    states: np.ndarray
    controls: np.ndarray
    stability: Stability


@dataclass(frozen=True)
class Derivatives:
    """Linearised one-step dynamics on the active DoF set C, for every timestep:

        dx_C[t+1] = A[t] dx_C[t] + B[t] du[t],   dx_C = [dq_C; dv_C]  (tangent space)

    F: (T, 2|C|, 2|C| + nu) = [A B], the one buffer A and B view (the backward pass reads F);
    A: (T, 2|C|, 2|C|), B: (T, 2|C|, nu); dofs: (|C|,) the DoF indices of C (into qvel).
    With C = all DoFs (and na = 0) A and B equal ``mujoco.mjd_transitionFD``. stability: the
    verdict of the scene's bounds on the T nominal rows as one trajectory (``judge_states``):
    derivatives around a state no rollout would accept are flagged, not silently used.
    """

    F: np.ndarray
    dofs: np.ndarray
    fd: FDConfig
    stability: Stability | None = None

    @property
    def A(self) -> np.ndarray:
        return self.F[:, :, :2 * len(self.dofs)]

    @property
    def B(self) -> np.ndarray:
        return self.F[:, :, 2 * len(self.dofs):]


class RolloutService:
    """Batched rollouts and FD derivatives on one scene.

    The route (C kernels or Batch, see the module docstring) is chosen once, here. Not for
    concurrent use from several Python threads (calls are serialised by a lock); give each
    thread its own service. ``close()`` (or leaving a ``with RolloutService(scene) as svc:``
    block) shuts the C kernels' thread pool down and drops the Batch; later calls raise
    RuntimeError.
    """

    def __init__(self, scene: Scene, config: RolloutConfig = RolloutConfig()):
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a dopt.Scene, got {type(scene).__name__}")
        if not isinstance(config, RolloutConfig):
            raise TypeError(f"config must be a dopt.RolloutConfig, got {type(config).__name__}")
        self.scene = scene
        self.model = scene.model
        self.config = config
        self.threads = config.threads or os.cpu_count() or 1
        self._uses_c_kernels = config.c_kernels and kernels.load() is not None
        route = CRoute if self._uses_c_kernels else BatchRoute
        self._route: BatchRoute | None = route(scene, self.threads)
        self._lock = threading.Lock()

    @property
    def uses_c_kernels(self) -> bool:
        """Whether derivatives and feedback rollouts run in dopt.kernels' C loops."""
        return self._uses_c_kernels

    # ------------------------------------------------------------------ lifetime
    def close(self) -> None:
        """Shut the C kernels' thread pool down and drop the Batch; idempotent. Any later
        call raises RuntimeError."""
        with self._lock:
            route, self._route = self._route, None
            if route is not None:
                route.close()

    @property
    def closed(self) -> bool:
        """Whether ``close()`` was called."""
        return self._route is None

    def __enter__(self) -> RolloutService:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _open_route(self) -> BatchRoute:
        """The route, for a call holding the lock; RuntimeError once closed."""
        if self._route is None:
            raise RuntimeError("RolloutService is closed")
        return self._route

    # ------------------------------------------------------------------ rollouts
    def rollout(self, initial_states, controls, *, record: Sequence = (),
                control_spec: int = CTRL, lengths=None) -> RolloutResult:
        """Run P open-loop rollouts of T steps in one batched call.

        Args:
            initial_states: (ns,) or (P, ns) mjSTATE_INTEGRATION rows.
            controls: (P, T, ncontrol) or (T, ncontrol) for every rollout, where ncontrol is
                ``mj_stateSize(model, control_spec)`` (nu for the default spec, ctrl).
            record: MjData field names and/or mjtState specs to record after each step.
            control_spec: mjtState bits within mjSTATE_USER that ``controls`` sets before each
                step (e.g. ctrl | eq_active for a picker that grasps and releases).
            lengths: (P,) ints in [1, T]: rollout p takes only its first ``lengths[p]`` steps
                (its final state is the one after them, its later records repeat its last,
                its verdict covers them), bit for bit as a call with its rows alone; None:
                all T.

        Returns:
            RolloutResult; its ``stability`` flags every rollout that broke the scene's
            ``StabilityBounds``, made MuJoCo warn or raise (reason "MuJoCo error: ...", e.g. an
            arena overflow; its records after the error are its last, NaN where none) or went
            non-finite, with the step and reason; the other rollouts are unaffected by them
            (bit-identical to a call without them).

        Raises:
            ValueError: bad shapes or dtypes, NaN/inf inputs.
            UnstableRolloutError: with ``RolloutConfig(on_unstable="raise")``, the first
                unstable rollout (which one, at which step, why).
            RuntimeError: the service is closed.
        """
        if not is_int(control_spec):
            raise TypeError(f"control_spec must be an int of mjtState bits, got {control_spec!r}")
        if control_spec & ~USER or not control_spec:
            raise ValueError(f"control_spec must be a non-empty subset of mjSTATE_USER "
                             f"({USER}), got {control_spec}")
        record = _check_record(record)
        ncontrol = mujoco.mj_stateSize(self.model, control_spec)
        u = float_array(controls, "controls")
        if u.ndim == 2:
            u = u[None]
        if u.ndim != 3 or u.shape[2] != ncontrol or u.shape[1] == 0 or u.shape[0] == 0:
            raise ValueError(f"controls must have shape (P, T, {ncontrol}) or (T, {ncontrol}) "
                             f"with P, T >= 1, got {np.shape(controls)}")
        x0 = check_states(self.model, initial_states, name="initial_states")
        n_x0 = x0.shape[0] if x0.ndim == 2 else 1
        if 1 not in (n_x0, u.shape[0]) and n_x0 != u.shape[0]:
            raise ValueError(f"initial_states has {n_x0} rollouts but controls has "
                             f"{u.shape[0]}; give one of them for all or P of each")
        P = max(u.shape[0], n_x0)
        u = np.broadcast_to(u, (P, u.shape[1], ncontrol))
        steps = _check_lengths(lengths, P, u.shape[1])
        with self._lock:
            final, records, verdict = self._open_route().rollout(x0, u, control_spec, record,
                                                                 steps)
        self._check_verdict(verdict, "rollout")
        return RolloutResult(final, records, verdict)

    def trajectory(self, initial_state, controls) -> Trajectory:
        """One open-loop rollout that keeps every state row: (ns,), (T, nu) -> Trajectory."""
        u = float_array(controls, "controls")
        if u.ndim != 2 or u.shape[1] != self.model.nu or not len(u):
            raise ValueError(f"controls must have shape (T, {self.model.nu}) with T >= 1, got "
                             f"{u.shape}")
        x0 = check_states(self.model, initial_state, batched=False, name="initial_state")
        spec = self.scene.layout.spec
        res = self.rollout(x0, u[None], record=(spec,))
        states = np.concatenate([x0[None], res.records[spec][0]], axis=0)
        ctrl = self.scene.layout["ctrl"]
        states[0, ctrl] = u[0]
        states[1:-1, ctrl] = u[1:]
        return Trajectory(states, np.array(u), res.stability)

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
            Trajectory with states (P, T+1, ns) (row t holds the applied u_t), the applied
            controls (P, T, nu) and the verdict on each rollout (as ``rollout``).
        """
        m = self.model
        x0 = check_states(m, initial_state, batched=False, name="initial_state")
        u = float_array(controls, "controls")
        ref = check_states(m, ref_states, batched=True, name="ref_states")
        K = float_array(gains, "gains")
        C = self.scene.as_dofs(dofs)
        T = u.shape[1] if u.ndim == 3 else 0
        if u.ndim != 3 or u.shape[2] != m.nu or T == 0 or not len(u):
            raise ValueError(f"controls must have shape (P, T, {m.nu}) with P, T >= 1, got "
                             f"{u.shape}")
        if ref.shape[0] != T:
            raise ValueError(f"ref_states must have shape ({T}, {self.scene.nstate}) (one row "
                             f"per step of controls), got {ref.shape}")
        if K.shape != (T, m.nu, 2 * len(C)):
            raise ValueError(f"gains must have shape ({T}, {m.nu}, {2 * len(C)}) (T, nu, "
                             f"2|C|), got {K.shape}")
        with self._lock:
            states, applied, verdict = self._open_route().feedback(x0, u, ref, K, C)
        self._check_verdict(verdict, "rollout_feedback")
        return Trajectory(states, applied, verdict)

    def _check_verdict(self, verdict: Stability, what: str) -> None:
        """Raise for the first unstable rollout when the config says so."""
        if self.config.on_unstable == "raise" and (first := verdict.first()):
            raise UnstableRolloutError(*first, what)

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
        if not isinstance(fd, FDConfig):
            raise TypeError(f"fd must be a dopt.FDConfig, got {type(fd).__name__}")
        x = check_states(m, states, batched=True, name="states")
        C = self.scene.dofs() if dofs is None else self.scene.as_dofs(dofs)
        check_fd_step(fd.eps, x, self.scene, C)
        with self._lock:
            F = self._open_route().derivatives(x, C, fd.eps, fd.centered)
        return Derivatives(F, C, fd, judge_states(self.scene, x))


def judge_states(scene: Scene, states: np.ndarray) -> Stability:
    """The scene's stability verdict on state rows (T, ns) read as one trajectory (P = 1):
    each row's velocities, flex vertex positions and edge lengths (from MuJoCo's position
    stage) against the bounds, and MuJoCo's own limits (``dopt.state.fault``); ``step`` is the
    first offending row. The energy bound, which needs a rollout's history, is not judged."""
    m, mon = scene.model, scene.monitor
    if mon.energy_judged:
        mon = Monitor(m, replace(mon.bounds, max_energy_gain=None))
    T = len(states)
    fields = {"qvel": states[None, :, scene.layout["qvel"]],
              "solver_niter": np.zeros((1, T), dtype=np.int32)}
    if mon.has_flex:
        d = mujoco.MjData(m)
        xpos, length = np.empty((1, T, m.nflexvert, 3)), np.empty((1, T, m.nflexedge))
        for t, row in enumerate(states):
            mujoco.mj_setState(m, d, row, scene.layout.spec)
            mujoco.mj_fwdPosition(m, d)
            xpos[0, t], length[0, t] = d.flexvert_xpos, d.flexedge_length
        fields.update(flexvert_xpos=xpos, flexedge_length=length)
    if "eq_active" in mon.record:
        fields["eq_active"] = (states[None, :, scene.layout["eq_active"]]
                               if "eq_active" in scene.layout.slices
                               else np.zeros((1, T, m.neq), dtype=np.uint8))
    scan = mon.start(1)
    scan.update(np.array([0]), 0, fields)
    for t, row in enumerate(states):
        why = fault(scene.layout, row)
        if why is not None:
            scan.flag(0, t, why)
            break
    return scan.result()


def _check_lengths(lengths, P: int, T: int) -> np.ndarray:
    """The steps of each of P rollouts of at most T: (P,) int64 in [1, T] (None: all T);
    TypeError / ValueError naming ``lengths`` otherwise."""
    if lengths is None:
        return np.full(P, T, dtype=np.int64)
    out = index_array(lengths, "lengths", T + 1)
    if np.ndim(lengths) != 1 or out.shape != (P,) or (out < 1).any():
        raise ValueError(f"lengths must be ({P},) step counts in [1, {T}], one per rollout, "
                         f"got {np.asarray(lengths).tolist()}")
    return out


def _check_record(record) -> tuple:
    """The record items of ``rollout``: a sequence of MjData field names and mjtState specs."""
    if isinstance(record, (str, int)) or not isinstance(record, Sequence):
        raise TypeError(f"record must be a sequence of MjData field names and mjtState specs, "
                        f"got {record!r}")
    for item in record:
        if isinstance(item, str):
            if not isinstance(getattr(mujoco.MjData, item, None), property):
                raise ValueError(f"record: {item!r} is not an MjData field")
        else:
            check_spec(item, "record item")
    return tuple(record)
