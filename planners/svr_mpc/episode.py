"""One MPC episode on a pushing task: the controller wiring (``build_controller``: iLQR-SVR;
``wire_controller``: any optimiser of ``planners.svr_mpc.optimisers``), ``run_svr_mpc`` and its
``SVRMPCResult``; ``run_trial`` for ``dopt.lab.sweep`` (``CapturingTrial``: with blow-up captures of
the executed episode under the sweep's folder). ``keep_controls`` (opt-in: about 280 KB a
trial) keeps the executed episode's start state and controls (``CONTROLS_FIELDS``), which
``planners.view`` re-simulates exactly.

Shapes: T horizon, nu controls, ns state row, c = |C| active DoFs.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from dopt.blowup import retire_captures
from dopt.mpc import MPC, MPCConfig, Plan, mpc_cost
from dopt.rollout import RolloutConfig, RolloutService
from dopt.scene import Scene
from dopt.tasks.push import warm_start
from dopt.tasks.push.contact import robot_contact
from dopt.tasks.push.costs import COST_PRESETS, PushWeights, goal_distance, push_cost
from dopt.tasks.push.task_model import TaskModel
from dopt.validation import check_int
from planners.ilqr import ILQR, ILQRConfig
from planners.svr import DofSelector, SelectionConfig, SVROptimiser
from planners.svr_mpc import authors_clock
from planners.svr_mpc.optimisers import (
    DEFAULT_OPTIMISER,
    OptimiserContext,
    OptimiserFactory,
    optimiser_factory,
)
from planners.svr_mpc.settings import (
    CLOCK_MODEL_MS,
    SVRMPCSettings,
    parse_row,
    split_params,
)
from planners.svr_mpc.trial_names import trial_key


@dataclass(frozen=True)
class SVRController:
    """A task instance wired for MPC: its scene, cost, rollout service, the optimiser (any
    ``dopt.mpc.Optimiser``; iLQR-SVR's, ``planners.svr.SVROptimiser``: selector -> one iLQR
    iteration -> selector, has the ``selector`` and ``ilqr`` below) and the goal object's
    distance to the goal (state row (ns,) -> m)."""

    task: TaskModel
    scene: Scene
    cost: object
    service: RolloutService
    optimiser: object
    goal_distance: Callable[[np.ndarray], float]

    @property
    def selector(self) -> DofSelector:
        return self.optimiser.selector

    @property
    def ilqr(self) -> ILQR:
        return self.optimiser.ilqr


def build_controller(task: TaskModel, selection: SelectionConfig, rng: np.random.Generator,
                     threads: int = 0, ilqr: ILQRConfig = ILQRConfig(),
                     weights: PushWeights = PushWeights()) -> SVRController:
    """Wire ``task`` to its push cost (``weights``), a rollout service with ``threads``
    threads, iLQR and a DoF selector drawing from ``rng``."""
    scene = Scene(task.model, stability=task.stability)
    cost = push_cost(task, scene, weights)
    service = RolloutService(scene, RolloutConfig(threads=threads))
    selector = DofSelector(scene.nv, task.robot_dofs, cost.costed_dofs, selection, rng)
    return SVRController(task, scene, cost, service,
                         SVROptimiser(ILQR(service, cost, ilqr), selector),
                         goal_distance(task, scene))


def wire_controller(task: TaskModel, settings: SVRMPCSettings, rng: np.random.Generator,
                    optimiser: str | OptimiserFactory = DEFAULT_OPTIMISER) -> SVRController:
    """Wire ``task`` to the push cost of ``settings.cost``, a rollout service with
    ``settings.threads`` threads and the optimiser that ``optimiser`` (a name of
    ``OPTIMISERS`` or a factory) builds from them, ``settings`` and ``rng``
    (``OptimiserContext``)."""
    name, factory = optimiser_factory(optimiser)
    scene = Scene(task.model, stability=task.stability)
    cost = push_cost(task, scene, COST_PRESETS[settings.cost])
    service = RolloutService(scene, RolloutConfig(threads=settings.threads))
    try:
        built = factory(OptimiserContext(task, scene, cost, service, settings, rng))
        if not callable(getattr(built, "optimise", None)):
            raise TypeError(f"optimiser {name!r}: its factory returned a "
                            f"{type(built).__name__!r}, which has no optimise(state, plan)")
    except BaseException:
        service.close()
        raise
    return SVRController(task, scene, cost, service, built, goal_distance(task, scene))


#: the goal distance is kept every this many executed steps (and at the last)
GOAL_DISTANCE_STRIDE = 10
#: the result fields of an episode run with ``keep_controls`` (what ``planners.view`` replays)
CONTROLS_FIELDS = ("start_state", "controls")


@dataclass(frozen=True)
class SVRMPCResult:
    """One MPC episode: its MPC cost (Eq. 5), whether the goal object reached the goal, the
    executed steps, the goal object's distance to the goal at start and end (m), per
    optimisation its duration on the episode's clock (ms), its process CPU time (ms), |C|,
    start step, lag (agent steps) and active set (a hex bit mask, bit j = DoF j:
    ``active_dofs``), mean lag, steps that started late (real clock), and the slowdown,
    timeout and clock it ran with; the goal object's distance to the goal every
    ``goal_distance_stride`` executed steps and at the last (m, the start first), the final
    state row (ns,) as a list, the line-search rollouts the stability verdict flagged, and
    whether the executed episode broke a stability bound (the reason names the step and
    bound), and the blow-up captures written of it (folders; ``run_trial``: relative to the
    sweep's folder). Lists are rounded (0.01 ms, 10 um, 1e-7) to keep trial files small.
    With ``keep_controls`` (``run_svr_mpc``) also the executed episode's start state (ns,)
    and controls (S, nu) as lists, and the final state unrounded, so that re-simulating the
    controls from the start (``dopt.view.replay_controls``) ends exactly on it; None (and
    absent from ``to_dict``) otherwise. held_steps: steps the authors' executor held the arm
    (``dopt.mpc``; 0 under Alg. 1); landed_at: per optimisation the row of its plan the agent
    went on from (-1: nothing landed)."""

    mpc_cost: float
    success: bool
    steps: int
    goal_distance_start: float
    goal_distance_end: float
    opt_ms: list
    n_dofs: list
    opt_step: list
    active_sets: list
    lag_steps_mean: float
    late_steps: int
    slowdown: float
    timeout: int
    goal_distance: list = field(default_factory=list)
    final_state: list = field(default_factory=list)
    n_unstable_rollouts: int = 0
    unstable: bool = False
    unstable_reason: str = ""
    clock: str = "real"
    cpu_ms: list = field(default_factory=list)
    lag_steps: list = field(default_factory=list)
    goal_distance_stride: int = GOAL_DISTANCE_STRIDE
    blowups: list = field(default_factory=list)
    start_state: list | None = None
    controls: list | None = None
    held_steps: int = 0
    landed_at: list = field(default_factory=list)

    @property
    def opt_ms_mean(self) -> float:
        return float(np.mean(self.opt_ms))

    @property
    def dofs_mean(self) -> float:
        return float(np.mean(self.n_dofs))

    def active_dofs(self, i: int) -> np.ndarray:
        """The active DoF set of optimisation ``i``: (c,) sorted indices."""
        return dofs_of_mask(self.active_sets[i])

    def to_dict(self) -> dict:
        """JSON-able form, with the means and the optimisation count (``CONTROLS_FIELDS``
        only when kept)."""
        out = {**asdict(self), "opt_ms_mean": self.opt_ms_mean, "dofs_mean": self.dofs_mean,
               "n_optimisations": len(self.opt_ms)}
        return {k: v for k, v in out.items() if k not in CONTROLS_FIELDS or v is not None}


def dofs_mask(dofs) -> str:
    """A DoF set as a hex bit mask (bit j set: DoF j in the set)."""
    return hex(sum(1 << int(j) for j in np.unique(np.asarray(dofs, dtype=int))))


def dofs_of_mask(mask: str) -> np.ndarray:
    """The sorted DoF indices (c,) of a hex bit mask written by ``dofs_mask``."""
    bits, out = int(mask, 16), []
    while bits:
        low = bits & -bits
        out.append(low.bit_length() - 1)
        bits ^= low
    return np.array(out, dtype=int)


def run_svr_mpc(settings: SVRMPCSettings = SVRMPCSettings(), seed: int = 0,
                history: list | None = None,
                on_step: Callable[[], None] | None = None,
                blowup_out: str | os.PathLike | None = None,
                blowup_label: str | None = None,
                optimiser: str | OptimiserFactory = DEFAULT_OPTIMISER,
                keep_controls: bool = False) -> SVRMPCResult:
    """One MPC episode of ``settings.selection.method`` on the task instance of ``seed``,
    optimised by ``optimiser`` (``planners.svr_mpc.optimisers``: a name of ``OPTIMISERS`` or
    a factory ``context -> optimiser``; default the paper's iLQR-SVR).

    The seed builds the task instance (the same for every method, so costs pair up against baseline:
    problem ``ours`` draws its layout from ``default_rng(seed)``; the authors' clutter loads
    their scene number ``seed``), the DoF selector's draws ([seed, 1]) and the control noise
    ([seed, 2]). The episode starts at the task's initial state with zero controls, or
    (``start.warm_start``) at the state the authors' set-up motion ends in with their push
    plan; it runs on the settings' clock (``timing``; real: real time times the slowdown)
    unless ``timing.synchronous``.
    ``history``: a list that receives the optimiser's ``history`` (``SVROptimiser``'s: each
    optimisation's set, importances, line-search step, regularisation and costs), with
    "contact_steps": the states of the new nominal in which the robot touches the pushed
    object (``dopt.tasks.push.contact``), of "horizon" + 1; an optimiser without one is a
    TypeError. ``on_step``: called after every executed
    agent step (``dopt.mpc.MPC``'s; a progress bar's count). ``blowup_out``: a run folder
    that receives blow-up captures of the executed episode (``dopt.mpc.MPC``'s;
    ``blowup_out/blowups/<blowup_label>``, default label ``<task>-<method>-seed<seed>``, the
    optimiser's name for the method's where it is not ``svr``). ``keep_controls``: the result
    keeps the executed episode's start state and controls and its final state unrounded
    (``SVRMPCResult``), for an exact replay.
    """
    import torch

    if not isinstance(settings, SVRMPCSettings):
        raise TypeError(f"settings must be SVRMPCSettings, got {type(settings).__name__}")
    check_int(seed, "seed", minimum=0)
    if not isinstance(keep_controls, bool):
        raise TypeError(f"keep_controls must be a bool, got {type(keep_controls).__name__}")
    name, _ = optimiser_factory(optimiser)        # ValueError / TypeError before any work

    torch.set_num_threads(1)
    seed = int(seed)
    task = settings.build_task(seed)
    ctl = wire_controller(task, settings, np.random.default_rng([seed, 1]), optimiser)
    radius = PushWeights().success_radius
    config = mpc_config(settings, task)
    if history is not None:
        keep_history(ctl, task, name)
    mpc = MPC(ctl.scene, ctl.optimiser, config, np.random.default_rng([seed, 2]),
              success=lambda x: ctl.goal_distance(x) < radius, on_step=on_step,
              blowup_out=blowup_out,
              blowup_label=blowup_label or f"{settings.task}-"
              f"{settings.selection.method if name == DEFAULT_OPTIMISER else name}-seed{seed}")
    start, plan = start_and_plan(settings, task, ctl.scene.nu)
    try:
        res = mpc.run(start, plan)
    finally:
        ctl.service.close()
    if history is not None:
        history.extend(ctl.optimiser.history)
    return episode_result(ctl, res, start, config, keep_controls)


def solve(settings: SVRMPCSettings, method: str | None = None, seed: int = 0,
          **episode) -> SVRMPCResult:
    """One trial in one call, as ``planners.pick_place.solve(settings, method, seed)``:
    ``method`` names a row (``parse_row``: a Table 1 row such as ``sum-t10-r1``, with its
    derivative variants and fixes, or a registered optimiser) applied over ``settings`` (None:
    the settings' own method, theta and rho, by the paper's iLQR-SVR); then one MPC episode on
    the task instance of ``seed`` (``run_svr_mpc``, which ``episode`` passes its other
    arguments to)."""
    if method is None:
        return run_svr_mpc(settings, seed, **episode)
    if not isinstance(method, str):
        raise TypeError(f"method must be a row name (str) or None, got {method!r}")
    if not isinstance(settings, SVRMPCSettings):
        raise TypeError(f"settings must be SVRMPCSettings, got {type(settings).__name__}")
    row = parse_row(method)
    return run_svr_mpc(row.apply(settings), seed, optimiser=row.optimiser, **episode)


def mpc_config(settings: SVRMPCSettings, task) -> MPCConfig:
    """The MPC loop's config of an episode: the settings' timeout and slowdown (else the
    task's), clock, noise, feedback and, on the model clock, the settings' fixed duration or
    else the task's cost model."""
    timing, execution = settings.timing, settings.execution
    if timing.clock == "authors":
        clock, ms = "model", authors_clock.model_ms(settings.task, settings.selection.method)
    else:
        clock, ms = timing.clock, (None if timing.clock != "model"
                                   else CLOCK_MODEL_MS[settings.task]
                                   if timing.clock_ms is None else (timing.clock_ms, 0.0))
    return MPCConfig(timeout=int(execution.timeout or task.timeout),
                     slowdown=float(timing.slowdown or task.slowdown),
                     synchronous=timing.synchronous, feedback=execution.feedback,
                     control_noise=float(execution.control_noise), clock=clock,
                     threads=float(timing.nominal_threads), model_ms=ms,
                     executor=execution.executor)


def keep_history(ctl, task, name: str) -> None:
    """Make the controller's optimiser keep its history, each new nominal probed for the
    states in which the robot touches the pushed object; a TypeError (the service closed)
    for an optimiser that keeps none."""
    if not hasattr(ctl.optimiser, "keep_history"):
        ctl.service.close()
        raise TypeError(f"history needs an optimiser that keeps one (keep_history, probe, "
                        f"history: planners.svr.SVROptimiser's); {name!r} does not")
    ctl.optimiser.keep_history = True
    touching = robot_contact(task)

    def contact_in_horizon(states: np.ndarray) -> dict:
        steps = touching(states)
        return {"contact_steps": int(steps.sum()), "horizon": len(steps) - 1}

    ctl.optimiser.probe = contact_in_horizon


def start_and_plan(settings: SVRMPCSettings, task, nu: int) -> tuple[np.ndarray, Plan]:
    """The episode's start state (ns,) and first plan (T, nu): with ``start.warm_start`` the
    state the authors' set-up motion ends in and their push plan, else the task's initial
    state and zero controls."""
    if settings.start.warm_start:
        start = warm_start.setup(task).final_state
        push = warm_start.WarmStartConfig(moving_tail=settings.start.push_tail)
        return start, Plan(warm_start.push(task, start, task.horizon, push).controls)
    return task.initial_state, Plan(np.zeros((task.horizon, nu)))


def episode_result(ctl, res, start: np.ndarray, config: MPCConfig,
                   keep_controls: bool) -> SVRMPCResult:
    """The ``SVRMPCResult`` of an executed episode ``res`` (``dopt.mpc.MPCResult``)."""
    S = len(res.controls)
    kept = sorted(set(range(0, S + 1, GOAL_DISTANCE_STRIDE)) | {S})
    final = res.states[-1] if keep_controls else np.round(res.states[-1], 7)
    return SVRMPCResult(
        mpc_cost=mpc_cost(ctl.cost, res), success=bool(res.success), steps=S,
        goal_distance_start=ctl.goal_distance(start),
        goal_distance_end=ctl.goal_distance(res.states[-1]),
        opt_ms=[round(1e3 * s, 2) for s in res.opt_seconds], n_dofs=list(res.n_dofs),
        opt_step=list(res.opt_step), active_sets=[dofs_mask(d) for d in res.dofs],
        lag_steps_mean=float(np.mean(res.lag_steps)), late_steps=int(res.late_steps),
        slowdown=config.slowdown, timeout=config.timeout,
        goal_distance=[round(ctl.goal_distance(res.states[t]), 5) for t in kept],
        final_state=[float(v) for v in final],
        n_unstable_rollouts=int(getattr(ctl.optimiser, "n_unstable_rollouts", 0)),
        unstable=bool(res.stability.unstable[0]),
        unstable_reason=(f"step {res.stability.step[0]}: {res.stability.reason[0]}"
                         if res.stability.unstable[0] else ""),
        clock=config.clock, cpu_ms=[round(1e3 * s, 2) for s in res.cpu_seconds],
        lag_steps=[int(v) for v in res.lag_steps], blowups=list(res.blowups),
        start_state=res.states[0].tolist() if keep_controls else None,
        controls=res.controls.tolist() if keep_controls else None,
        held_steps=int(res.held_steps), landed_at=[int(v) for v in res.landed_at])


def run_trial(params: dict, report: Callable[[], None] | None = None,
              blowup_out: str | os.PathLike | None = None,
              keep_controls: bool = False) -> dict:
    """``run_svr_mpc`` for ``dopt.lab.sweep``: params holds the settings flat
    (``SVRMPCSettings.params``), "seed" and, where it is not ``svr``, "optimiser"
    (``trial_params``) -> ``SVRMPCResult.to_dict()``; ``report`` (the sweep's) is called after
    every agent step. ``blowup_out``: the sweep's folder, which receives the blow-up captures of
    the episode as ``blowups/<trial key>`` (``trial_key``), listed in the result relative to
    it; those of an earlier run of the trial move to ``blowups/outdated/`` first.
    ``keep_controls``: the result also holds "start_state" (ns,) and "controls" (S, nu) of
    the executed episode (``CONTROLS_FIELDS``; about 280 KB a trial) and its final state
    unrounded, for ``dopt-view``'s exact replay; the params, and so the key, are the same
    either way."""
    settings, seed, optimiser = split_params(params)
    if blowup_out is None:
        return run_svr_mpc(settings, seed, on_step=report, optimiser=optimiser,
                           keep_controls=keep_controls).to_dict()
    retire_captures(blowup_out, [trial_key(params)])
    res = run_svr_mpc(settings, seed, on_step=report, blowup_out=blowup_out,
                      blowup_label=trial_key(params), optimiser=optimiser,
                      keep_controls=keep_controls).to_dict()
    return {**res, "blowups": [os.path.relpath(b, blowup_out) for b in res["blowups"]]}


@dataclass(frozen=True)
class CapturingTrial:
    """``trial`` (default ``run_trial``) with blow-up captures under the sweep's folder ``out``
    (its ``blowup_out``): a picklable trial function for ``dopt.lab.sweep``'s pools and Ray (on a
    cluster the captures land on the worker's file system). ``keep_controls``: passed on to
    ``trial`` when True (``run_trial``'s)."""

    out: str
    trial: Callable = run_trial
    keep_controls: bool = False

    def __call__(self, params: dict, report: Callable[[], None] | None = None) -> dict:
        keep = {"keep_controls": True} if self.keep_controls else {}
        return self.trial(params, report, blowup_out=self.out, **keep)
