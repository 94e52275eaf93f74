"""iLQR-SVR inside asynchronous MPC on the pushing tasks: the state-vector-reduction paper's
pipeline as one library call.

``build_controller`` wires a task instance (``dopt.tasks.PUSH_TASKS``) to its cost, a rollout
service, iLQR and a DoF selector; ``run_svr_mpc`` runs one MPC episode (Alg. 1) with it and
returns an ``SVRMPCResult``::

    from planners.svr_mpc import SVRMPCSettings, run_svr_mpc
    result = run_svr_mpc(SVRMPCSettings(task="clutter", method="svr-sum"), seed=0)
    result.mpc_cost, result.success, result.dofs_mean

``summarize`` turns many finished trials of one task into the rows of Table 1 (costs normalised
by baseline on the same task instance), ``paired`` compares each row with baseline seed by
seed. ``SVRMPCSettings.paper(task, row)`` is the paper's protocol for one of its nine Table 1
rows (``TABLE1_ROWS``): the paper's cost (Eq. 2, no end-effector term), the authors' initial
plan (``dopt.tasks.push.warm_start``), their 5 % control noise, and the virtual clock.

Shapes: T horizon, nu controls, ns state row, c = |C| active DoFs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from dopt.mpc import CLOCKS, MPC, MPCConfig, Plan, mpc_cost
from dopt.rollout import FDConfig, RolloutConfig, RolloutService
from dopt.scene import Scene
from dopt.stats import mean_ci
from dopt.tasks import get_task
from dopt.tasks.push import warm_start
from dopt.tasks.push.costs import COST_PRESETS, PushWeights, goal_distance, push_cost
from dopt.tasks.push.task_model import TaskModel
from dopt.validation import check_config, check_int
from planners.ilqr import ILQR, ILQRConfig
from planners.keypoints import KeypointConfig
from planners.svr import METHODS, DofSelector, SelectionConfig, SVROptimiser, paper_theta

#: the nine rows of the paper's Table 1 by name: (method, theta, rho)
TABLE1_ROWS = {
    "baseline": ("baseline", 0, 1.0),
    "rand-t5": ("rand", 5, 1.0),
    "naive": ("naive", 0, 1.0),
    "svd-t10-r1": ("svr-svd", 10, 1.0),
    "svd-t10-r500": ("svr-svd", 10, 500.0),
    "svd-t5-r1": ("svr-svd", 5, 1.0),
    "sum-t10-r1": ("svr-sum", 10, 1.0),
    "sum-t10-r500": ("svr-sum", 10, 500.0),
    "sum-t5-r1": ("svr-sum", 5, 1.0),
}

#: the authors' cost per task where it is not Eq. 2 alone (``COST_PRESETS["paper"]``): their
#: push_soft task file adds a terminal reach residual (``dopt.tasks.push.costs``)
PAPER_COSTS = {"soft": "paper-reach"}

#: the model clock per task, ms per optimisation = a + b |C| on the nominal 2 threads: fitted
#: by ``python -m planners.bench clock`` (docs/results/clock-model.json)
CLOCK_MODEL_MS = {"clutter": (38.9, 2.05), "soft": (146.7, 9.29), "soft_rigid": (289.6, 30.92)}


def row_name(method: str, theta: int, rho: float) -> str:
    """A trial's Table 1 row: ``baseline``, ``naive``, ``rand-t<theta>``,
    ``sum-t<theta>-r<rho>`` or ``svd-t<theta>-r<rho>`` (``TABLE1_ROWS`` names nine)."""
    if method in ("baseline", "naive"):
        return method
    if method == "rand":
        return f"rand-t{theta}"
    return f"{method[4:]}-t{theta}-r{rho:g}"


def parse_row(spec: str) -> tuple[str, int, float, dict]:
    """A row of ``TABLE1_ROWS`` by name, optionally with derivative variants
    (``variant_settings``): ``sum-t10-r1+skip5``, ``sum-t10-r1+adaptive``,
    ``sum-t10-r1+skip5+boxqp``, ``sum-t10-r1+central``. Returns (method, theta, rho, the
    ``SVRMPCSettings`` fields the variants set)."""
    name, *mods = spec.split("+")
    if name not in TABLE1_ROWS:
        raise ValueError(f"unknown Table 1 row {name!r}: choose from {', '.join(TABLE1_ROWS)}")
    return (*TABLE1_ROWS[name], variant_settings(mods, f"row {spec!r}"))


def variant_settings(mods, what: str = "variants") -> dict:
    """The ``SVRMPCSettings`` fields of derivative variants: ``skip<K>`` or ``adaptive`` (key
    timesteps, ``planners.keypoints``), ``boxqp`` (the box-QP backward pass), ``central`` (the
    authors' central differences, eps 1e-6); ``what`` names them in errors."""
    over: dict = {}
    for mod in mods:
        if mod == "boxqp" and "box_qp" not in over:
            over["box_qp"] = True
        elif mod == "central" and "fd_centered" not in over:
            over.update(fd_centered=True, fd_eps=1e-6)
        elif mod not in ("boxqp", "central") and "keypoints" not in over:
            try:
                kp = KeypointConfig.parse(mod)
            except ValueError:
                raise ValueError(f"{what}: a variant is skip<K>, adaptive, boxqp or central, "
                                 f"got {mod!r}") from None
            over.update(keypoints=kp.method, fd_skip=kp.skip)
        else:
            raise ValueError(f"{what}: {mod!r} repeats a variant")
    return over


def derivatives_tag(p: dict) -> str:
    """The derivative variant of a trial's params as a row-label suffix: `` +central``
    (central differences), `` +skip<K>`` or `` +adaptive`` (key timesteps), `` +boxqp``; ''
    for forward differences (eps 1e-3) at every timestep and a plain backward pass."""
    tag = ""
    if p.get("fd_centered") or p.get("fd_eps", 1e-3) != 1e-3:
        tag += " +central" if p.get("fd_centered") else f" +fd{p['fd_eps']:g}"
    if p.get("keypoints", "every") == "adaptive":
        tag += " +adaptive"
    elif p.get("keypoints", "every") == "skip" and p.get("fd_skip", 1) > 1:
        tag += f" +skip{p['fd_skip']}"
    return tag + (" +boxqp" if p.get("box_qp") else "")


@dataclass(frozen=True)
class SVRMPCSettings:
    """One MPC trial's settings (the seed comes separately).

    Attributes:
        task: a name of ``dopt.tasks.PUSH_TASKS`` (clutter, soft, soft_rigid).
        method: a DoF-selection method (``planners.svr.METHODS``).
        rho: SVR importance threshold.
        theta: random DoFs per iteration; None: the paper's for the method (rand 5, svr 10).
        slowdown: agent wall time per step over dt; None: the task's (the paper's).
        timeout: Y, agent steps; None: the task's (the paper's).
        feedback: execute u + K (x - x_nominal) (the authors did not).
        control_noise: Gaussian noise on executed controls, fraction of each control's range.
        synchronous: the agent waits for the optimiser (deterministic; tests, debugging).
        threads: simulation threads (0: one per core).
        cost: a name of ``dopt.tasks.push.costs.COST_PRESETS``: ``ee`` (with the end-effector
            term, ours), ``paper`` (Eq. 2 alone) or ``paper-reach`` (Eq. 2 with the authors'
            soft-task reach residual).
        warm_start: start from the authors' set-up state and initial push plan
            (``dopt.tasks.push.warm_start``) instead of the task's start and zero controls.
        clock: ``real``, ``virtual`` or ``model`` (``dopt.mpc``); nominal_threads: the thread
            count a virtual duration divides the CPU time by; the model clock's coefficients
            are the task's ``CLOCK_MODEL_MS``.
        fd_centered, fd_eps: the finite differences (default forward 1e-3; the authors:
            centred 1e-6).
        keypoints, fd_skip: the timesteps the finite differences cover (``every``, ``skip``
            every fd_skip-th, ``adaptive``; ``planners.keypoints``), A and B linear between.
        box_qp: control limits in the backward pass (``ILQRConfig.box_qp``).
    """

    task: str = "clutter"
    method: str = "svr-sum"
    rho: float = 1.0
    theta: int | None = None
    slowdown: float | None = None
    timeout: int | None = None
    feedback: bool = False
    control_noise: float = 0.0
    synchronous: bool = False
    threads: int = 0
    cost: str = "ee"
    warm_start: bool = False
    clock: str = "real"
    nominal_threads: float = 2.0
    fd_centered: bool = False
    fd_eps: float = 1e-3
    keypoints: str = "every"
    fd_skip: int = 1
    box_qp: bool = False

    def __post_init__(self):
        get_task(self.task)                       # ValueError naming the known tasks
        if self.method not in METHODS:
            raise ValueError(f"unknown method {self.method!r}; choose from {METHODS}")
        if self.cost not in COST_PRESETS:
            raise ValueError(f"unknown cost {self.cost!r}; choose from {tuple(COST_PRESETS)}")
        if self.clock not in CLOCKS:
            raise ValueError(f"unknown clock {self.clock!r}; choose from {CLOCKS}")
        # rho, control_noise finite >= 0; theta an int >= 0 or None; slowdown finite > 0 or
        # None; timeout an int >= 1 or None; feedback, synchronous bools; threads an int >= 0
        check_config(self, positive=("slowdown", "nominal_threads", "fd_eps"),
                     minimum={"rho": 0.0, "theta": 0, "timeout": 1, "control_noise": 0.0,
                              "threads": 0, "fd_skip": 1})
        _ = self.ilqr                              # ValueError naming a bad keypoint method
        if self.synchronous and self.clock != "real":
            raise ValueError("synchronous runs have no clock: use clock='real' with it")

    @classmethod
    def paper(cls, task: str, row: str = "sum-t10-r1", **overrides) -> SVRMPCSettings:
        """The paper's protocol for ``row`` (a name of ``TABLE1_ROWS``) on ``task``: the
        authors' cost for the task (``PAPER_COSTS``: Eq. 2, on soft with their reach
        residual), their initial plan, 5 % control noise, the virtual clock."""
        if row not in TABLE1_ROWS:
            raise ValueError(f"unknown Table 1 row {row!r}; choose from {tuple(TABLE1_ROWS)}")
        method, theta, rho = TABLE1_ROWS[row]
        return cls(**{"task": task, "method": method, "theta": theta, "rho": rho,
                      "cost": PAPER_COSTS.get(task, "paper"), "warm_start": True,
                      "control_noise": 0.05,
                      "clock": "virtual", **overrides})

    @property
    def ilqr(self) -> ILQRConfig:
        """iLQR's config: the finite differences, their key timesteps, the box QP."""
        return ILQRConfig(fd=FDConfig(eps=float(self.fd_eps), centered=bool(self.fd_centered)),
                          keypoints=KeypointConfig(self.keypoints, skip=int(self.fd_skip)),
                          box_qp=bool(self.box_qp))

    @property
    def selection(self) -> SelectionConfig:
        """The DoF selector's config (theta None -> the paper's for the method)."""
        theta = paper_theta(self.method) if self.theta is None else self.theta
        return SelectionConfig(self.method, rho=float(self.rho), theta=int(theta))


@dataclass(frozen=True)
class SVRController:
    """A task instance wired for MPC: its scene, cost, rollout service, the optimiser
    (``planners.svr.SVROptimiser``: selector -> one iLQR iteration -> selector) and the goal
    object's distance to the goal (state row (ns,) -> m)."""

    task: TaskModel
    scene: Scene
    cost: object
    service: RolloutService
    optimiser: SVROptimiser
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
    scene = Scene(task.model)
    cost = push_cost(task, scene, weights)
    service = RolloutService(scene, RolloutConfig(threads=threads))
    selector = DofSelector(scene.nv, task.robot_dofs, cost.costed_dofs, selection, rng)
    return SVRController(task, scene, cost, service,
                         SVROptimiser(ILQR(service, cost, ilqr), selector),
                         goal_distance(task, scene))


#: the goal distance is kept every this many executed steps (and at the last)
GOAL_DISTANCE_STRIDE = 10


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
    bound). Lists are rounded (0.01 ms, 10 um, 1e-7) to keep trial files small."""

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
        """JSON-able form, with the means and the optimisation count."""
        return {**asdict(self), "opt_ms_mean": self.opt_ms_mean, "dofs_mean": self.dofs_mean,
                "n_optimisations": len(self.opt_ms)}


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
                history: list | None = None) -> SVRMPCResult:
    """One MPC episode of ``settings.method`` on the task instance of ``seed``.

    The seed builds the task layout (the same for every method, so costs pair up against
    baseline), the DoF selector's draws ([seed, 1]) and the control noise ([seed, 2]). The
    episode starts at the task's initial state with zero controls, or (``warm_start``) at the
    state the authors' set-up motion ends in with their push plan; it runs on the settings'
    clock (real: real time times the slowdown) unless ``synchronous``. ``history``: a list
    that receives ``SVROptimiser.history`` (each optimisation's set and importances).
    """
    import torch

    if not isinstance(settings, SVRMPCSettings):
        raise TypeError(f"settings must be SVRMPCSettings, got {type(settings).__name__}")
    check_int(seed, "seed", minimum=0)

    torch.set_num_threads(1)
    seed = int(seed)
    task = get_task(settings.task)(np.random.default_rng(seed))
    ctl = build_controller(task, settings.selection, np.random.default_rng([seed, 1]),
                           settings.threads, settings.ilqr,
                           COST_PRESETS[settings.cost])
    radius = PushWeights().success_radius
    config = MPCConfig(timeout=int(settings.timeout or task.timeout),
                       slowdown=float(settings.slowdown or task.slowdown),
                       synchronous=settings.synchronous, feedback=settings.feedback,
                       control_noise=float(settings.control_noise), clock=settings.clock,
                       threads=float(settings.nominal_threads),
                       model_ms=(CLOCK_MODEL_MS[settings.task] if settings.clock == "model"
                                 else None))
    ctl.optimiser.keep_history = history is not None
    mpc = MPC(ctl.scene, ctl.optimiser, config, np.random.default_rng([seed, 2]),
              success=lambda x: ctl.goal_distance(x) < radius)
    if settings.warm_start:
        start = warm_start.setup(task).final_state
        plan = Plan(warm_start.push(task, start, task.horizon).controls)
    else:
        start, plan = task.initial_state, Plan(np.zeros((task.horizon, ctl.scene.nu)))
    try:
        res = mpc.run(start, plan)
    finally:
        ctl.service.close()
    if history is not None:
        history.extend(ctl.optimiser.history)
    S = len(res.controls)
    kept = sorted(set(range(0, S + 1, GOAL_DISTANCE_STRIDE)) | {S})
    return SVRMPCResult(
        mpc_cost=mpc_cost(ctl.cost, res), success=bool(res.success), steps=S,
        goal_distance_start=ctl.goal_distance(start),
        goal_distance_end=ctl.goal_distance(res.states[-1]),
        opt_ms=[round(1e3 * s, 2) for s in res.opt_seconds], n_dofs=list(res.n_dofs),
        opt_step=list(res.opt_step), active_sets=[dofs_mask(d) for d in res.dofs],
        lag_steps_mean=float(np.mean(res.lag_steps)), late_steps=int(res.late_steps),
        slowdown=config.slowdown, timeout=config.timeout,
        goal_distance=[round(ctl.goal_distance(res.states[t]), 5) for t in kept],
        final_state=[float(v) for v in np.round(res.states[-1], 7)],
        n_unstable_rollouts=ctl.optimiser.n_unstable_rollouts,
        unstable=bool(res.stability.unstable[0]),
        unstable_reason=(f"step {res.stability.step[0]}: {res.stability.reason[0]}"
                         if res.stability.unstable[0] else ""),
        clock=config.clock, cpu_ms=[round(1e3 * s, 2) for s in res.cpu_seconds],
        lag_steps=[int(v) for v in res.lag_steps])


# ----------------------------------------------------------------------- many trials
def run_trial(params: dict) -> dict:
    """``run_svr_mpc`` for ``dopt.sweep``: params holds the ``SVRMPCSettings`` fields and
    "seed" -> ``SVRMPCResult.to_dict()``."""
    p = dict(params)
    seed = p.pop("seed")
    return run_svr_mpc(SVRMPCSettings(**p), seed).to_dict()


def trial_key(p: dict) -> str:
    """File-name key of a trial's params: everything that changes its outcome (timeout None,
    the task's own, is Y0; settings at their defaults add nothing)."""
    parts = [p["task"], p["method"], f"rho{p['rho']:g}", f"theta{p['theta']}",
             f"slow{p['slowdown']:g}", f"Y{p['timeout'] or 0}", f"seed{p['seed']}"]
    if p.get("feedback"):
        parts.append("fb")
    if p.get("control_noise"):
        parts.append(f"noise{p['control_noise']:g}")
    if p.get("cost", "ee") != "ee":
        parts.append(f"cost{p['cost']}")
    if p.get("warm_start"):
        parts.append("ws")
    if p.get("clock", "real") != "real":
        parts.append(f"clock{p['clock']}{p.get('nominal_threads', 2.0):g}")
    if p.get("fd_centered") or p.get("fd_eps", 1e-3) != 1e-3:
        parts.append(f"fd{'c' if p.get('fd_centered') else 'f'}{p.get('fd_eps', 1e-3):g}")
    if p.get("keypoints", "every") != "every":
        parts.append("kpadaptive" if p["keypoints"] == "adaptive"
                     else f"skip{p.get('fd_skip', 1)}")
    if p.get("box_qp"):
        parts.append("boxqp")
    return "-".join(parts)


#: a goal object that ends farther than this from the goal (m) was knocked over and rolled away;
#: the paper removes such outliers from its clutter means, and so do we (they are counted)
OUTLIER_DISTANCE = 0.5


def row_label(p: dict) -> str:
    """Table row of a trial: ``row_name`` of its method, theta and rho, its
    ``derivatives_tag`` and ' +fb' when it executed the K feedback term."""
    return (row_name(p["method"], p["theta"], p["rho"]) + derivatives_tag(p)
            + (" +fb" if p.get("feedback") else ""))


def summarize(records: list[dict], baseline: str = "baseline", level: float = 0.90) -> dict:
    """Per row (``row_label``), over the trials of one task:

    - ``mpc_cost_normalised_mean``, ``_ci90``: MPC cost over the ``baseline`` row's on the
      same task instance (seed), mean and Student-t half-width at ``level`` over the trials
      that are neither outliers (goal object ending > ``OUTLIER_DISTANCE`` from the goal, as
      the paper's clutter means leave out; counted in ``outliers``) nor unstable (the executed
      episode broke a stability bound: its cost is not that of a physical push; counted in
      ``n_unstable_trials``), on either side of the ratio;
    - ``mpc_cost_normalised_median``: median of the same per-seed ratios over all trials;
    - ``mpc_cost_median_ratio``: median cost of the row over median cost of baseline (all
      trials, unpaired): the statistic the authors' own data reproduce their Table 1 with;
    - ``opt_ms_mean`` (duration on the episode's clock), ``n_dofs_mean``, ``lag_steps_mean``,
      ``success_rate``, ``goal_distance_end_median``, ``n_trials``, ``n_unstable_trials``,
      ``n_unstable_rollouts``.

    records: {"params", "result"} of finished trials of one task.
    """
    by: dict = {}
    for r in records:
        by.setdefault(row_label(r["params"]), {})[r["params"]["seed"]] = r["result"]

    def outlier(v):
        return v["goal_distance_end"] > OUTLIER_DISTANCE

    def excluded(v):
        return outlier(v) or bool(v.get("unstable", False))

    base_all = {k: v["mpc_cost"] for k, v in by.get(baseline, {}).items()}
    base = {k: c for k, c in base_all.items() if not excluded(by[baseline][k])}
    out = {}
    for row, trials in by.items():
        res = list(trials.values())
        norm_all = [v["mpc_cost"] / base_all[k] for k, v in trials.items() if k in base_all]
        norm = [v["mpc_cost"] / base[k] for k, v in trials.items()
                if k in base and not excluded(v)]
        mean, ci = mean_ci(norm, level) if norm else (float("nan"), float("nan"))
        costs = [v["mpc_cost"] for v in res]
        out[row] = {
            "mpc_cost_normalised_mean": mean,
            "mpc_cost_normalised_ci90": ci,
            "mpc_cost_normalised_median": float(np.median(norm_all)) if norm_all else None,
            "mpc_cost_median_ratio": (float(np.median(costs) / np.median(list(base_all.values())))
                                      if base_all else None),
            "mpc_cost_median": float(np.median(costs)),
            "opt_ms_mean": float(np.mean([v["opt_ms_mean"] for v in res])),
            "n_dofs_mean": float(np.mean([v["dofs_mean"] for v in res])),
            "success_rate": float(np.mean([v["success"] for v in res])),
            "goal_distance_end_median": float(np.median([v["goal_distance_end"] for v in res])),
            "goal_distance_end_mean": float(np.mean([v["goal_distance_end"] for v in res])),
            "lag_steps_mean": float(np.mean([v["lag_steps_mean"] for v in res])),
            "outliers": int(sum(outlier(v) for v in res)),
            "n_trials": len(res),
            "n_unstable_trials": int(sum(v.get("unstable", False) for v in res)),
            "n_unstable_rollouts": int(sum(v.get("n_unstable_rollouts", 0) for v in res)),
        }
    return out


def paired_ratio(numerator: dict, denominator: dict, level: float = 0.90) -> dict:
    """Cost ratios on the same seeds: {seed: cost} x 2 -> {"ratio_geomean", "ratio_ci90":
    [lo, hi], "better", "pairs"}: the geometric mean of the per-seed ratios with a t-interval
    on their logs (cost ratios are skewed), and the pairs where the numerator cost less."""
    seeds = sorted(set(numerator) & set(denominator))
    logs = [np.log(numerator[k] / denominator[k]) for k in seeds]
    if not logs:
        return {"ratio_geomean": None, "ratio_ci90": None, "better": 0, "pairs": 0}
    mean, ci = mean_ci(logs, level)
    return {"ratio_geomean": float(np.exp(mean)),
            "ratio_ci90": [float(np.exp(mean - ci)), float(np.exp(mean + ci))],
            "better": int(sum(x < 0 for x in logs)), "pairs": len(logs)}


def paired(records: list[dict], baseline: str = "baseline", level: float = 0.90) -> dict:
    """Per row other than ``baseline``: ``paired_ratio`` of its MPC costs over baseline's on
    the same seeds (all trials, outliers included)."""
    by: dict = {}
    for r in records:
        by.setdefault(row_label(r["params"]), {})[r["params"]["seed"]] = r["result"]["mpc_cost"]
    return {row: paired_ratio(costs, by.get(baseline, {}), level)
            for row, costs in by.items() if row != baseline}


def _variant_pairs(records: list[dict], plain) -> dict:
    """{row label: (plain row label, {seed: result}, {seed: plain result})} for every row
    (``row_label``) that differs from its ``plain(params)`` row, over the seeds both ran."""
    by: dict = {}
    plain_of: dict = {}
    for r in records:
        p = r["params"]
        label, base = row_label(p), plain(p)
        by.setdefault(label, {})[p["seed"]] = r["result"]
        if base != label:
            plain_of[label] = base
    out = {}
    for label, base in plain_of.items():
        seeds = sorted(set(by[label]) & set(by.get(base, {})))
        if seeds:
            out[label] = (base, {k: by[label][k] for k in seeds}, {k: by[base][k] for k in seeds})
    return out


def _costs(results: dict) -> dict:
    return {k: v["mpc_cost"] for k, v in results.items()}


def feedback_effect(records: list[dict], level: float = 0.90) -> dict:
    """Per row with both variants: MPC cost with feedback over open loop on the same seed.

    Returns {row: {"ratio_geomean", "ratio_ci90": [lo, hi], "better", "pairs",
    "success_open_loop", "success_feedback"}} (``paired_ratio``; "better": pairs where
    feedback cost less).
    """
    pairs = _variant_pairs(records, lambda p: row_label({**p, "feedback": False}))
    return {base: {**paired_ratio(_costs(fb), _costs(open_loop), level),
                   "success_open_loop": int(sum(v["success"] for v in open_loop.values())),
                   "success_feedback": int(sum(v["success"] for v in fb.values()))}
            for base, fb, open_loop in pairs.values()}


def derivatives_effect(records: list[dict], level: float = 0.90) -> dict:
    """Per row run with a derivative variant (``derivatives_tag``: central differences, key
    timesteps, box QP) and without it: the variant's MPC cost over the plain row's on the
    same seeds.

    Returns {row label: {"versus": the plain row's label, "ratio_geomean", "ratio_ci90",
    "better", "pairs" (``paired_ratio``; "better": pairs where the variant cost less),
    "lag_steps_mean", "versus_lag_steps_mean", "opt_ms_mean", "versus_opt_ms_mean" (means
    over the paired trials)}}.
    """
    def plain(p):
        return row_label({**p, "keypoints": "every", "fd_skip": 1, "box_qp": False,
                          "fd_centered": False, "fd_eps": 1e-3})

    def mean(results, field):
        return float(np.mean([v[field] for v in results.values()]))

    return {label: {"versus": base, **paired_ratio(_costs(var), _costs(ref), level),
                    **{f"{who}{field}": mean(res, field)
                       for field in ("lag_steps_mean", "opt_ms_mean")
                       for who, res in (("", var), ("versus_", ref))}}
            for label, (base, var, ref) in _variant_pairs(records, plain).items()}

