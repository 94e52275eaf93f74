"""iLQR-SVR inside asynchronous MPC on the pushing tasks: the state-vector-reduction paper's
pipeline as one library call.

``build_controller`` wires a task instance (``dopt.tasks.PUSH_TASKS``) to its cost, a rollout
service, iLQR and a DoF selector; ``run_svr_mpc`` runs one MPC episode (Alg. 1) with it and
returns an ``SVRMPCResult``::

    from planners.svr_mpc import SVRMPCSettings, run_svr_mpc
    result = run_svr_mpc(SVRMPCSettings(task="clutter", method="svr-sum"), seed=0)
    result.mpc_cost, result.success, result.dofs_mean

``summarize`` turns many finished trials of one task into the rows of Table 1 (costs normalised
by baseline on the same task instance).

Shapes: T horizon, nu controls, ns state row, c = |C| active DoFs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from dopt.mpc import MPC, MPCConfig, Plan, mpc_cost
from dopt.rollout import RolloutConfig, RolloutService
from dopt.scene import Scene
from dopt.stats import mean_ci
from dopt.tasks import get_task
from dopt.tasks.push.costs import PushWeights, goal_distance, push_cost
from dopt.tasks.push.task_model import TaskModel
from dopt.validation import check_config, check_int
from planners.ilqr import ILQR, ILQRConfig
from planners.svr import METHODS, DofSelector, SelectionConfig, SVROptimiser, paper_theta


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

    def __post_init__(self):
        get_task(self.task)                       # ValueError naming the known tasks
        if self.method not in METHODS:
            raise ValueError(f"unknown method {self.method!r}; choose from {METHODS}")
        # rho, control_noise finite >= 0; theta an int >= 0 or None; slowdown finite > 0 or
        # None; timeout an int >= 1 or None; feedback, synchronous bools; threads an int >= 0
        check_config(self, positive=("slowdown",),
                     minimum={"rho": 0.0, "theta": 0, "timeout": 1, "control_noise": 0.0,
                              "threads": 0})

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
                     threads: int = 0, ilqr: ILQRConfig = ILQRConfig()) -> SVRController:
    """Wire ``task`` to its push cost, a rollout service with ``threads`` threads, iLQR and a
    DoF selector drawing from ``rng``."""
    scene = Scene(task.model)
    cost = push_cost(task, scene)
    service = RolloutService(scene, RolloutConfig(threads=threads))
    selector = DofSelector(scene.nv, task.robot_dofs, cost.costed_dofs, selection, rng)
    return SVRController(task, scene, cost, service,
                         SVROptimiser(ILQR(service, cost, ilqr), selector),
                         goal_distance(task, scene))


@dataclass(frozen=True)
class SVRMPCResult:
    """One MPC episode: its MPC cost (Eq. 5), whether the goal object reached the goal, the
    executed steps, the goal object's distance to the goal at start and end (m), per
    optimisation its wall time (ms), |C|, start step and active set, mean lag (agent steps per
    optimisation), steps that started late, and the slowdown and timeout it ran with; the goal
    object's distance to the goal after every executed step (m, S + 1 values, the start
    first), the final state row (ns,) as a list, the line-search rollouts the stability
    verdict flagged, and whether the executed episode broke a stability bound (the reason
    names the step and bound)."""

    mpc_cost: float
    success: bool
    steps: int
    goal_distance_start: float
    goal_distance_end: float
    opt_ms: list
    n_dofs: list
    opt_step: list
    active_dofs: list
    lag_steps_mean: float
    late_steps: int
    slowdown: float
    timeout: int
    goal_distance: list = field(default_factory=list)
    final_state: list = field(default_factory=list)
    n_unstable_rollouts: int = 0
    unstable: bool = False
    unstable_reason: str = ""

    @property
    def opt_ms_mean(self) -> float:
        return float(np.mean(self.opt_ms))

    @property
    def dofs_mean(self) -> float:
        return float(np.mean(self.n_dofs))

    def to_dict(self) -> dict:
        """JSON-able form, with the means and the optimisation count."""
        return {**asdict(self), "opt_ms_mean": self.opt_ms_mean, "dofs_mean": self.dofs_mean,
                "n_optimisations": len(self.opt_ms)}


def run_svr_mpc(settings: SVRMPCSettings = SVRMPCSettings(), seed: int = 0) -> SVRMPCResult:
    """One MPC episode of ``settings.method`` on the task instance of ``seed``.

    The seed builds the task layout (the same for every method, so costs pair up against
    baseline), the DoF selector's draws ([seed, 1]) and the control noise ([seed, 2]). The
    plan starts at zero controls; the episode runs in real time times the slowdown unless
    ``synchronous``.
    """
    import torch

    if not isinstance(settings, SVRMPCSettings):
        raise TypeError(f"settings must be SVRMPCSettings, got {type(settings).__name__}")
    check_int(seed, "seed", minimum=0)

    torch.set_num_threads(1)
    seed = int(seed)
    task = get_task(settings.task)(np.random.default_rng(seed))
    ctl = build_controller(task, settings.selection, np.random.default_rng([seed, 1]),
                           settings.threads)
    radius = PushWeights().success_radius
    config = MPCConfig(timeout=int(settings.timeout or task.timeout),
                       slowdown=float(settings.slowdown or task.slowdown),
                       synchronous=settings.synchronous, feedback=settings.feedback,
                       control_noise=float(settings.control_noise))
    mpc = MPC(ctl.scene, ctl.optimiser, config, np.random.default_rng([seed, 2]),
              success=lambda x: ctl.goal_distance(x) < radius)
    try:
        res = mpc.run(task.initial_state, Plan(np.zeros((task.horizon, ctl.scene.nu))))
    finally:
        ctl.service.close()
    return SVRMPCResult(
        mpc_cost=mpc_cost(ctl.cost, res), success=bool(res.success), steps=len(res.controls),
        goal_distance_start=ctl.goal_distance(task.initial_state),
        goal_distance_end=ctl.goal_distance(res.states[-1]),
        opt_ms=[1e3 * s for s in res.opt_seconds], n_dofs=list(res.n_dofs),
        opt_step=list(res.opt_step), active_dofs=[np.asarray(d).tolist() for d in res.dofs],
        lag_steps_mean=float(np.mean(res.lag_steps)), late_steps=int(res.late_steps),
        slowdown=config.slowdown, timeout=config.timeout,
        goal_distance=[round(ctl.goal_distance(x), 6) for x in res.states],
        final_state=np.asarray(res.states[-1], dtype=float).tolist(),
        n_unstable_rollouts=ctl.optimiser.n_unstable_rollouts,
        unstable=bool(res.stability.unstable[0]),
        unstable_reason=(f"step {res.stability.step[0]}: {res.stability.reason[0]}"
                         if res.stability.unstable[0] else ""))


# ----------------------------------------------------------------------- many trials
def run_trial(params: dict) -> dict:
    """``run_svr_mpc`` for ``dopt.sweep``: params holds the ``SVRMPCSettings`` fields and
    "seed" -> ``SVRMPCResult.to_dict()``."""
    p = dict(params)
    seed = p.pop("seed")
    return run_svr_mpc(SVRMPCSettings(**p), seed).to_dict()


def trial_key(p: dict) -> str:
    """File-name key of a trial's params: everything that changes its outcome (timeout None,
    the task's own, is Y0)."""
    parts = [p["task"], p["method"], f"rho{p['rho']:g}", f"theta{p['theta']}",
             f"slow{p['slowdown']:g}", f"Y{p['timeout'] or 0}", f"seed{p['seed']}"]
    if p.get("feedback"):
        parts.append("fb")
    if p.get("control_noise"):
        parts.append(f"noise{p['control_noise']:g}")
    return "-".join(parts)


#: a goal object that ends farther than this from the goal (m) was knocked over and rolled away;
#: the paper removes such outliers from its clutter means, and so do we (they are counted)
OUTLIER_DISTANCE = 0.5


def row_label(p: dict) -> str:
    """Table row of a trial: its method, ' +fb' when it executed the K feedback term."""
    return p["method"] + (" +fb" if p.get("feedback") else "")


def summarize(records: list[dict], baseline: str = "baseline", level: float = 0.90) -> dict:
    """Per row (``row_label``): MPC cost normalised by the ``baseline`` row's on the same task
    instance (seed), mean and CI half-width at ``level`` over the trials that are not outliers,
    and the median over all; optimisation time, DoFs, success rate, trial and outlier counts.

    records: {"params", "result"} of finished trials of one task.
    """
    by: dict = {}
    for r in records:
        by.setdefault(row_label(r["params"]), {})[
            (r["params"]["seed"], r["params"]["rho"], r["params"]["theta"])] = r["result"]

    def outlier(v):
        return v["goal_distance_end"] > OUTLIER_DISTANCE

    base = {k[0]: v["mpc_cost"] for k, v in by.get(baseline, {}).items() if not outlier(v)}
    out = {}
    for method, trials in by.items():
        res = list(trials.values())
        paired = {k: v for k, v in trials.items() if k[0] in base}
        norm_all = [v["mpc_cost"] / base[k[0]] for k, v in paired.items()]
        norm = [v["mpc_cost"] / base[k[0]] for k, v in paired.items() if not outlier(v)]
        mean, ci = mean_ci(norm, level) if norm else (float("nan"), float("nan"))
        out[method] = {
            "mpc_cost_normalised_mean": mean,
            "mpc_cost_normalised_ci90": ci,
            "mpc_cost_normalised_median": float(np.median(norm_all)) if norm_all else None,
            "opt_ms_mean": float(np.mean([v["opt_ms_mean"] for v in res])),
            "dofs_mean": float(np.mean([v["dofs_mean"] for v in res])),
            "success_rate": float(np.mean([v["success"] for v in res])),
            "goal_distance_end_median": float(np.median([v["goal_distance_end"] for v in res])),
            "lag_steps_mean": float(np.mean([v["lag_steps_mean"] for v in res])),
            "outliers": int(sum(outlier(v) for v in res)),
            "trials": len(res),
            "n_unstable_trials": int(sum(v.get("unstable", False) for v in res)),
            "n_unstable_rollouts": int(sum(v.get("n_unstable_rollouts", 0) for v in res)),
        }
    return out


def feedback_effect(records: list[dict], level: float = 0.90) -> dict:
    """Per method with both variants: MPC cost with feedback over open loop on the same seed.

    Returns {method: {"ratio_geomean", "ratio_ci90": [lo, hi], "better", "pairs",
    "success_open_loop", "success_feedback"}}: the geometric mean of the paired ratios with a
    t-interval on their logs (cost ratios are skewed), and how many pairs feedback won.
    """
    by: dict = {}
    for r in records:
        p = r["params"]
        by.setdefault(p["method"], {}).setdefault(p["seed"], {})[bool(p.get("feedback"))] = \
            r["result"]
    out = {}
    for method, seeds in by.items():
        pairs = [v for v in seeds.values() if len(v) == 2]
        if not pairs:
            continue
        logs = [np.log(v[True]["mpc_cost"] / v[False]["mpc_cost"]) for v in pairs]
        mean, ci = mean_ci(logs, level)
        out[method] = {
            "ratio_geomean": float(np.exp(mean)),
            "ratio_ci90": [float(np.exp(mean - ci)), float(np.exp(mean + ci))],
            "better": int(sum(x < 0 for x in logs)), "pairs": len(pairs),
            "success_open_loop": int(sum(v[False]["success"] for v in pairs)),
            "success_feedback": int(sum(v[True]["success"] for v in pairs)),
        }
    return out
