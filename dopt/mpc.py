"""Asynchronous MPC (Alg. 1 of the state-vector-reduction paper) and its MPC_cost (Eq. 5).

An *agent* thread steps the "real" system (its own MjData) in real time, one step every
``dt * slowdown`` wall seconds: it executes the first control of the current plan, drops it and
pads the plan with its last control. An *optimiser* thread repeatedly reads the agent's current
state, improves the plan (one optimiser iteration) and publishes it, shifted by the number of
steps the agent executed meanwhile, so that control t of the plan is applied at the time it was
computed for. Policy lag is therefore real: a slower optimiser acts on older states.

The heavy work of both threads runs in MuJoCo (``mj_step``, ``mujoco.batch``) and torch, which
release the GIL; the agent sleeps between steps. The synchronous mode (the agent waits for the
optimiser, ``steps_per_plan`` steps per optimisation) is deterministic, for tests and debugging.

Executors (``MPCConfig.executor``): ``alg1`` is the above, the paper's Alg. 1 (a plan that
runs out is padded with its last control; a plan lands shifted by its lag). ``authors`` is the
executing thread of the authors' data generator (DMackRus/iLQR_SVR ``GenTestingData.cpp``,
``SingleAsynchronusRun`` / ``AsyncronusMPCWorker``): the agent holds a buffer of controls and
a cursor into it; it applies buffered controls only while the cursor is below
``min(apply_limit, T)`` (theirs: 80) and otherwise holds the arm under gravity compensation
(zero commanded control: dopt's robots are gravity compensated by MuJoCo's ``gravcomp``) until
a plan lands; the buffer is empty at the start (the arm holds through the first
optimisation, whose warm start is the initial plan); a landed plan's cursor starts at the
row of its nominal nearest the agent's state at landing (L1 over positions and velocities of
the plan's DoF set, rows 0..T-2, an error below ``NEAREST_MAX_L1``), else at min(lag, T - 1).
An optimiser whose returned plan has ``info["keep"]`` true lands nothing once a plan
executes (the executing plan goes on; ``Unoptimised`` after its first plan).

Clocks (``MPCConfig.clock``): ``real`` is the above. ``virtual`` and ``model`` run the same
schedule in one thread on a virtual time line: the agent takes step k at virtual time
k dt slowdown; an optimisation that starts at virtual time c from the agent's state then lasts
its measured CPU time (``time.process_time``: all threads of the process, which runs nothing
else meanwhile) divided by ``threads`` (``virtual``), or ``a + b |C|`` ms (``model``,
a fixed cost model, so the same seed gives the same episode bit for bit, on any machine
whose OpenBLAS runs ``dopt.blas``'s kernels);
the agent executes the old plan for the steps that fall before c + duration, and the new
plan lands shifted by them.
On every clock an optimisation starts from a state the optimiser has not started from: one
that ends before the agent's next step waits for it (an optimiser faster than the control
period runs once per step, not over and over from the same state).
Lag then is what the algorithm costs, immune to other processes on the machine, so trials can
run in parallel.

dopt knows no planner: the optimiser is any object with ``optimise(state, plan) -> Plan``.

Blow-up captures (``MPC(..., blowup_out=OUT)``, opt-in): when the executed episode first breaks
a stability bound, and when a step makes MuJoCo warn or leaves no valid state (which raises
``UnstableRolloutError``), the agent writes the last ``dopt.blowup.KEEP`` executed state
rows up to the one after the failing step, the model and the reason to
``OUT/blowups/<blowup_label>`` (``dopt.blowup``; ``dopt-view`` opens it at that step).
``MPCResult.blowups`` and ``UnstableRolloutError.capture`` name them (after a warning the last
row is the state MuJoCo reset the data to; the reason names the body the warning points at).
Writing one holds up the agent (on the real clock: late steps), once per failure.
"""

from __future__ import annotations

import logging
import os
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Protocol

import mujoco
import numpy as np

from dopt.blowup import KEEP, capture_dir, save_blowup, warning_body
from dopt.errors import UnstableRolloutError
from dopt.scene import Scene
from dopt.stability import Stability
from dopt.state import INTEGRATION, check_states, fault
from dopt.validation import check_config, check_int, float_array, index_array

log = logging.getLogger(__name__)
CLOCKS = ("real", "virtual", "model")
EXECUTORS = ("alg1", "authors")
#: the authors' landing search starts from this smallest error (``AsyncronusMPCWorker``): a
#: plan whose nominal rows are all at least this far (L1) from the state lands at its lag
NEAREST_MAX_L1 = 1000.0
#: the largest ``MPCConfig.control_noise`` (a standard deviation, as a fraction of each
#: control's range): beyond the whole range a draw leaves it nearly every step, so the noise
#: is no longer a perturbation of the plan; far beyond (1e154 and up) the controls' squares,
#: and so the MPC cost, overflow to +inf
MAX_CONTROL_NOISE = 1.0
_BAD = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
        mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADCTRL)


@dataclass(frozen=True)
class Plan:
    """A control plan for the next T steps.

    controls: (T, nu). Optional feedback: states (T+1, ns) the nominal rows, K (T, nu, 2c)
    gains on the DoF set dofs (c,). info: what the optimiser reports (timings, |C|, cost).
    """

    controls: np.ndarray
    states: np.ndarray | None = None
    K: np.ndarray | None = None
    dofs: np.ndarray | None = None
    info: dict = field(default_factory=dict)

    def shifted(self, steps: int) -> Plan:
        """Drop the first ``steps`` controls and pad with the last one (gains pad with 0)."""
        steps = check_int(steps, "steps")
        if steps <= 0:
            return self
        T = len(self.controls)
        s = min(steps, T)
        pad = np.repeat(self.controls[-1:], s, axis=0)
        out = replace(self, controls=np.concatenate([self.controls[s:], pad]))
        if self.states is not None:
            out = replace(out, states=np.concatenate(
                [self.states[s:], np.repeat(self.states[-1:], s, axis=0)]))
        if self.K is not None:
            out = replace(out, K=np.concatenate([self.K[s:], np.zeros_like(self.K[:s])]))
        return out


def check_plan(plan, scene: Scene, name: str = "plan") -> Plan:
    """A Plan that fits ``scene``: controls (T, nu) finite with T >= 1; states (T+1, ns), K
    (T, nu, 2c) and dofs (c,) valid DoF indices where given (K needs dofs, or covers all
    DoFs). TypeError / ValueError naming ``plan.<field>`` otherwise."""
    if not isinstance(plan, Plan):
        raise TypeError(f"{name} must be a dopt.mpc.Plan, got {type(plan).__name__}")
    nu = scene.nu
    u = float_array(plan.controls, f"{name}.controls")
    if u.ndim != 2 or u.shape[1] != nu or not len(u):
        raise ValueError(f"{name}.controls must have shape (T, {nu}) with T >= 1, got "
                         f"{u.shape}")
    T = len(u)
    if plan.states is not None:
        check_states(scene.model, plan.states, batched=True, name=f"{name}.states")
        if np.shape(plan.states)[0] != T + 1:
            raise ValueError(f"{name}.states must have shape ({T + 1}, {scene.nstate}) (T+1 "
                             f"rows), got {np.shape(plan.states)}")
    if plan.K is not None:
        c = scene.nv if plan.dofs is None else len(index_array(plan.dofs, f"{name}.dofs",
                                                              scene.nv))
        K = float_array(plan.K, f"{name}.K")
        if K.shape != (T, nu, 2 * c):
            raise ValueError(f"{name}.K must have shape ({T}, {nu}, {2 * c}) (T, nu, 2|C|), "
                             f"got {K.shape}")
    elif plan.dofs is not None:     # without gains the set may be empty: nothing optimised
        index_array(plan.dofs, f"{name}.dofs", scene.nv, allow_empty=True)
    return plan


class Optimiser(Protocol):
    def optimise(self, state: np.ndarray, plan: Plan) -> Plan:
        """One optimisation from the state row (ns,) starting at the current plan."""


@dataclass(frozen=True)
class MPCConfig:
    """timeout: task timeout Y in agent steps. slowdown: wall seconds per agent step over the
    model timestep (1 = real time). synchronous: the agent waits for the optimiser and runs
    ``steps_per_plan`` steps per optimisation. feedback: add K (x - x_nominal) on the measured
    state to the executed control (the paper's authors did not). control_noise: standard
    deviation of Gaussian noise on executed controls, as a fraction of each control's range
    (at most ``MAX_CONTROL_NOISE``). warmup: optimiser iterations before the agent starts.
    clock: ``real``, ``virtual`` or ``model`` (module docstring); threads: the nominal thread
    count a virtual duration divides the CPU time by (2: this project's reference machine);
    model_ms: (a, b) of the model clock, ms per optimisation = a + b |C|. executor: ``alg1``
    or ``authors`` (module docstring); apply_limit: the authors' executor applies buffered
    controls while its cursor is below min(apply_limit, T), then holds."""

    timeout: int
    slowdown: float = 1.0
    synchronous: bool = False
    steps_per_plan: int = 1
    feedback: bool = False
    control_noise: float = 0.0
    warmup: int = 0
    clock: str = "real"
    threads: float = 2.0
    model_ms: tuple[float, float] | None = None
    executor: str = "alg1"
    apply_limit: int = 80

    def __post_init__(self):
        check_config(self, positive=("slowdown", "threads"),
                     minimum={"timeout": 1, "steps_per_plan": 1, "control_noise": 0,
                              "warmup": 0, "apply_limit": 1},
                     maximum={"control_noise": MAX_CONTROL_NOISE})
        if self.executor not in EXECUTORS:
            raise ValueError(f"executor must be one of {EXECUTORS}, got {self.executor!r}")
        if self.clock not in CLOCKS:
            raise ValueError(f"clock must be one of {CLOCKS}, got {self.clock!r}")
        if self.synchronous and self.clock != "real":
            raise ValueError("synchronous runs have no clock: use clock='real' with it")
        if self.clock == "model":
            ms = self.model_ms
            if (not isinstance(ms, tuple) or len(ms) != 2
                    or not all(isinstance(v, (int, float)) and np.isfinite(v) and v >= 0
                               for v in ms) or not sum(ms) > 0):
                raise ValueError(f"clock='model' needs model_ms=(a, b): ms per optimisation "
                                 f"= a + b |C|, finite, >= 0, not both 0; got {ms!r}")


@dataclass(frozen=True)
class MPCResult:
    """states: (S+1, ns) executed state rows (row t holds the control executed at step t);
    controls: (S, nu) executed; S = steps run (timeout, or earlier on success). success: the
    success condition was met. opt_seconds: wall time of each optimisation; opt_step: the agent
    step each optimisation started from; n_dofs: |C| of each; dofs: the active set of each;
    lag_steps: agent steps elapsed during each optimisation; late_steps: agent steps that
    started behind schedule (real clock); cpu_seconds: process CPU time of each optimisation;
    opt_seconds is its duration on the clock the episode ran on (wall, CPU / threads, or the
    cost model); stability: the verdict on the executed episode (one rollout,
    judged by the scene's ``StabilityBounds`` after every agent step; a broken bound is
    reported here, MuJoCo warnings and non-finite states raise); blowups: the blow-up
    capture folders written (``MPC``'s ``blowup_out``; the module docstring); landed_at: the
    row of each optimisation's plan the agent went on from (alg1: its lag; authors: the
    nearest nominal row; -1: nothing landed); held_steps: agent steps under the authors'
    executor's hold (alg1: 0)."""

    states: np.ndarray
    controls: np.ndarray
    success: bool
    opt_seconds: list
    opt_step: list
    n_dofs: list
    dofs: list
    lag_steps: list
    late_steps: int
    stability: Stability
    cpu_seconds: list = field(default_factory=list)
    blowups: tuple = ()
    landed_at: list = field(default_factory=list)
    held_steps: int = 0


class MPC:
    """Runs one MPC episode of an optimiser on a scene.

    Args:
        scene: the real system's model (the agent steps its own MjData of it).
        optimiser: see ``Optimiser``.
        config: MPCConfig.
        rng: generator of the control noise.
        success: optional predicate on a state row that ends the task early.
        on_step: optional, called with no argument after every agent step (a progress bar's
            count; it must be quick: on the real clock it runs on the agent's schedule).
        blowup_out: optional run folder: a failure of the executed episode writes a blow-up
            capture to ``blowup_out/blowups/<blowup_label>`` (``-2``, ... where one exists;
            the module docstring). None (default): no capture.
        blowup_label: the captures' name (in the folder, the console and the viewer).
    """

    def __init__(self, scene: Scene, optimiser: Optimiser, config: MPCConfig,
                 rng: np.random.Generator, success: Callable[[np.ndarray], bool] | None = None,
                 on_step: Callable[[], None] | None = None,
                 blowup_out: str | os.PathLike | None = None, blowup_label: str = "mpc"):
        if not isinstance(scene, Scene):
            raise TypeError(f"scene must be a dopt.Scene, got {type(scene).__name__}")
        if not callable(getattr(optimiser, "optimise", None)):
            raise TypeError(f"optimiser must have an optimise(state, plan) method, got "
                            f"{type(optimiser).__name__}")
        if not isinstance(config, MPCConfig):
            raise TypeError(f"config must be a dopt.mpc.MPCConfig, got {type(config).__name__}")
        if not isinstance(rng, np.random.Generator):
            raise TypeError("rng must be a numpy.random.Generator")
        for name, f in (("success", success), ("on_step", on_step)):
            if f is not None and not callable(f):
                raise TypeError(f"{name} must be callable, got {type(f).__name__}")
        if blowup_out is not None and not isinstance(blowup_out, (str, os.PathLike)):
            raise TypeError(f"blowup_out must be a folder path or None, got "
                            f"{type(blowup_out).__name__}")
        if not isinstance(blowup_label, str):
            raise TypeError(f"blowup_label must be a string, got {type(blowup_label).__name__}")
        self.blowup_out, self.blowup_label = blowup_out, blowup_label
        self.scene, self.optimiser, self.config = scene, optimiser, config
        self.rng, self.success, self.on_step = rng, success, on_step
        m = scene.model
        span = np.where(m.actuator_ctrllimited.astype(bool),
                        m.actuator_ctrlrange[:, 1] - m.actuator_ctrlrange[:, 0], 1.0)
        self._noise_std = config.control_noise * span
        self._lock = threading.Lock()

    def run(self, initial_state: np.ndarray, plan: Plan) -> MPCResult:
        """Run until the timeout or success from the state row (ns,) and an initial plan."""
        x0 = check_states(self.scene.model, initial_state, batched=False, name="initial_state")
        self._reset(x0, check_plan(plan, self.scene))
        for _ in range(self.config.warmup):
            self._optimise_once()
        if self.config.clock != "real":
            self._virtual_loop()
        elif self.config.synchronous:
            while not self._done:
                self._optimise_once()
                for _ in range(self.config.steps_per_plan):
                    if not self._done:
                        self._agent_step()
        else:
            worker = threading.Thread(target=self._optimiser_loop, name="mpc-optimiser",
                                      daemon=True)
            # the agent needs the GIL for ~0.1 ms per step; with the default 5 ms switch
            # interval the optimiser's Python code could hold it past the agent's deadline
            interval = sys.getswitchinterval()
            sys.setswitchinterval(min(interval, self._period / 20))
            worker.start()
            try:
                self._agent_loop()
            finally:
                self._stop.set()
                worker.join()
                sys.setswitchinterval(interval)
            if self._error is not None:
                raise self._error
        n = self._step
        return MPCResult(np.array(self._states[:n + 1]), np.array(self._controls[:n]),
                         self._succeeded, self._log["seconds"], self._log["step"],
                         self._log["n_dofs"], self._log["dofs"], self._log["lag"], self._late,
                         self._scan.result(), self._log["cpu"], tuple(self._blowups),
                         self._log["landed"], self._held)

    # ---------------------------------------------------------------- internals
    def _reset(self, x0: np.ndarray, plan: Plan) -> None:
        m = self.scene.model
        self._data = mujoco.MjData(m)
        mujoco.mj_setState(m, self._data, x0, INTEGRATION)
        mujoco.mj_forward(m, self._data)
        self._plan, self._step, self._consumed, self._late = plan, 0, 0, 0
        # the authors' executor: its buffer (None: empty, the arm holds) and cursor into it
        self._buffer, self._cursor, self._held = None, 0, 0
        self._states, self._controls = [x0.copy()], []
        self._succeeded, self._error, self._blowups = False, None, []
        self._stop = threading.Event()
        self._log = {"seconds": [], "step": [], "n_dofs": [], "dofs": [], "lag": [], "cpu": [],
                     "landed": []}
        self._scan = self.scene.monitor.start(1)

    @property
    def _done(self) -> bool:
        return self._succeeded or self._step >= self.config.timeout or self._stop.is_set()

    def _optimise_once(self, clock: float | None = None) -> float:
        """One optimisation from the agent's current state; the new plan lands at once (real
        clock: shifted by the steps the agent took meanwhile). ``clock``: the virtual time it
        starts at; the agent steps that fall before its end are taken first. Returns its
        duration on the episode's clock (s)."""
        with self._lock:
            state, plan, start = self._states[-1].copy(), self._warm_start(), self._step
        t0, c0 = time.perf_counter(), time.process_time()
        new = check_plan(self.optimiser.optimise(state, plan), self.scene,
                         "plan returned by the optimiser: plan")
        seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
        dofs = new.dofs if new.dofs is not None else np.arange(self.scene.nv)
        if clock is not None:
            if self.config.clock == "model":
                a, b = self.config.model_ms
                seconds = (a + b * len(dofs)) / 1e3
            else:
                seconds = cpu / self.config.threads
            while not self._done and self._step * self._period < clock + seconds:
                self._agent_step()
        with self._lock:
            # controls the agent has taken since `start` (it takes one before stepping, so
            # this can be one ahead of _step): row 0 of the new plan is for step `start`
            lag = self._consumed - start
            landed = self._land(new, lag)
            lg = self._log
            lg["landed"].append(landed)
            lg["seconds"].append(seconds)
            lg["step"].append(start)
            lg["lag"].append(lag)
            lg["cpu"].append(cpu)
            lg["n_dofs"].append(len(dofs))
            lg["dofs"].append(np.asarray(dofs).tolist())
        return seconds

    def _warm_start(self) -> Plan:
        """The plan the next optimisation starts from: the executing plan from its current
        row (alg1: the plan itself; authors: the buffer from its cursor, padded with its last
        control; the initial plan while the buffer is empty)."""
        if self.config.executor == "authors" and self._buffer is not None:
            return self._buffer.shifted(self._cursor)
        return self._plan

    def _land(self, new: Plan, lag: int) -> int:
        """Make ``new`` (row 0 for the state the optimisation started from, ``lag`` agent
        steps ago) the executing plan; the row the agent goes on from (-1: ``new`` keeps the
        executing plan, nothing lands)."""
        if new.info.get("keep") and (self._buffer is not None
                                     or self.config.executor == "alg1"):
            return -1
        if self.config.executor == "alg1":
            self._plan = new.shifted(lag)
            return lag
        T = len(new.controls)
        row = min(lag, T - 1)
        if new.states is not None and T > 1:
            err = np.abs(self._deviation(new.states[:T - 1], new.dofs)).sum(axis=1)
            best = int(np.argmin(err))            # the first of equal errors, as theirs
            if err[best] < NEAREST_MAX_L1:
                row = best
        self._buffer, self._cursor = new, row
        return row

    def _virtual_loop(self) -> None:
        """Optimisations back to back on the virtual time line (module docstring); one that
        ends before the agent's next step waits for it."""
        clock = 0.0
        while not self._done:
            start = self._step
            clock += self._optimise_once(clock)
            if self._step == start and not self._done:
                clock = max(clock, self._step * self._period)
                self._agent_step()

    def _agent_step(self) -> None:
        m, d = self.scene.model, self._data
        with self._lock:
            if self.config.executor == "authors":
                u = self._buffered_control()
            else:
                plan = self._plan
                u = plan.controls[0].copy()
                if self.config.feedback and plan.K is not None and plan.states is not None:
                    u += plan.K[0] @ self._deviation(plan.states[0], plan.dofs)
                self._plan = plan.shifted(1)
            self._consumed += 1
        if u is None:                          # the authors' hold: gravity compensation only
            u = np.zeros(m.nu)
            self._held += 1
        elif self._noise_std.any():
            u += self.rng.normal(0.0, self._noise_std)
        d.ctrl[:] = u
        row = self.scene.state_of(d)             # the row holds the control executed now
        mujoco.mj_step(m, d)
        bad = [w for w in _BAD if d.warning[w].number]
        nxt = self.scene.state_of(d)
        if reason := bad[0].name if bad else fault(self.scene.layout, nxt):
            err = UnstableRolloutError(0, self._step, reason, "mpc agent")
            body = warning_body(m, bad[0], d.warning[bad[0]].lastinfo) if bad else None
            err.capture = self._capture(row, nxt, reason if body is None else
                                        f"{reason} (body {m.body(body).name or body})")
            raise err
        if not self._scan.unstable[0]:
            fields = {f: np.asarray(getattr(d, f))[None, None] for f in self.scene.monitor.record}
            if len(self._scan.update(np.zeros(1, int), self._step, fields)):
                log.warning("MPC agent: the executed episode broke a stability bound at step "
                            "%d (%s)", self._step, self._scan.reason[0])
                self._capture(row, nxt, self._scan.reason[0])
        with self._lock:
            self._states[-1] = row
            self._controls.append(u)
            self._states.append(nxt)
            self._step += 1
            if self.success is not None and self.success(nxt):
                self._succeeded = True
        if self.on_step is not None:
            self.on_step()

    def _buffered_control(self) -> np.ndarray | None:
        """The authors' executor's next control (u + K dx with ``feedback``), advancing its
        cursor; None: hold (the buffer is empty or its cursor reached min(apply_limit, T))."""
        buf, i = self._buffer, self._cursor
        if buf is None or i >= min(self.config.apply_limit, len(buf.controls)):
            return None
        self._cursor += 1
        u = buf.controls[i].copy()
        if self.config.feedback and buf.K is not None and buf.states is not None:
            u += buf.K[i] @ self._deviation(buf.states[i], buf.dofs)
        return u

    def _capture(self, row: np.ndarray, nxt: np.ndarray, reason: str) -> str | None:
        """With ``blowup_out``: a blow-up capture of the current step failing for ``reason``,
        the executed rows up to ``row`` (this step's, with its control) and ``nxt`` (the state
        after it), the last KEEP of them; its folder (None: none asked, or it could not be
        written, which is logged and leaves the episode running)."""
        if self.blowup_out is None:
            return None
        with self._lock:
            past = self._states[-(KEEP - 1):]
        rows = np.array(past[:-1] + [row, nxt])
        try:
            out = save_blowup(capture_dir(self.blowup_out, self.blowup_label), self.scene.model,
                              rows, self._step, reason, spec=self.scene.layout.spec,
                              label=self.blowup_label)
        except OSError as e:
            log.error("MPC agent: the blow-up capture of step %d was not written: %s",
                      self._step, e)
            return None
        self._blowups.append(str(out))
        return str(out)

    def _deviation(self, ref: np.ndarray, dofs) -> np.ndarray:
        """[q_C (-) q_ref_C ; v_C - v_ref_C] of the agent's state against nominal rows ref
        (..., ns) over the DoFs ``dofs`` (None: all): (..., 2c)."""
        lay = self.scene.layout
        C = np.arange(self.scene.nv) if dofs is None else np.asarray(dofs)
        x = self._states[-1]
        dq = self.scene.tangent.difference(ref[..., lay["qpos"]], x[lay["qpos"]], 1.0, C)
        return np.concatenate([dq, x[lay["qvel"]][C] - ref[..., lay["qvel"]][..., C]], axis=-1)

    @property
    def _period(self) -> float:
        """Wall seconds per agent step."""
        return self.scene.model.opt.timestep * self.config.slowdown

    def _agent_loop(self) -> None:
        period = self._period
        start = time.perf_counter()
        while not self._done:
            if self._error is not None:
                return
            due = start + self._step * period
            wait = due - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
            else:
                self._late += 1
            self._agent_step()

    def _optimiser_loop(self) -> None:
        try:
            while not self._done:
                start = self._step
                self._optimise_once()
                while self._step == start and not self._done and self._error is None:
                    time.sleep(self._period / 10)        # wait for the agent's next state
        except Exception as e:  # surfaced in the caller's thread
            log.exception("optimiser failed")
            self._error = e
            self._stop.set()


def mpc_cost(cost, result: MPCResult) -> float:
    """MPC_cost (Eq. 5): the task cost of the executed trajectory, l_f at its last state.

    ``cost`` has ``total(states (S+1, ns), controls (S, nu))`` (e.g. dopt.costs.QuadraticCost).
    """
    return float(cost.total(result.states, result.controls))
