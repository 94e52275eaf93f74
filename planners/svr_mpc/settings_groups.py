"""The groups of an SVR MPC trial's settings (``SVRMPCSettings``), one idea each: which DoFs
each optimisation keeps (``DofSelection``), the scene a seed builds (``PushScene``), where an
episode starts (``PushStart``), the clock that turns an optimisation into agent steps of lag
(``Timing``) and how the agent executes the plans (``Execution``). How iLQR differentiates is
``planners.ilqr.Derivatives``.

Each group's fields keep the names a trial's params record them under (the flat record,
``SVRMPCSettings.params``), so a field's name is one word everywhere: its attribute, its
flag (``dopt.lab.flags``: the help text is the field's line in its group's Attributes) and
its key in a trial's params.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from dopt.lab.provenance import rooted
from dopt.mpc import CLOCKS, EXECUTORS, MAX_CONTROL_NOISE
from dopt.tasks import PUSH_PROBLEMS
from dopt.validation import check_config
from planners.svr import METHODS, SelectionConfig, paper_theta

#: the problems a trial can run on: ``ours`` (dopt's own scenes, ``dopt.tasks.PUSH_TASKS``) or
#: ``authors`` (the authors' scenes, objects and contacts, ``dopt.tasks.push.authors``)
PROBLEMS = PUSH_PROBLEMS

#: the clocks a trial can run on: ``dopt.mpc.CLOCKS`` and ``authors``, the model clock fitted
#: to the authors' own optimisation times (``planners.svr_mpc.authors_clock``)
SVR_CLOCKS = CLOCKS + ("authors",)


@dataclass(frozen=True)
class DofSelection:
    """Which DoFs each optimisation keeps in C: a Table 1 row's rule (``planners.svr``).

    Attributes:
        method: a DoF-selection method (``planners.svr.METHODS``).
        rho: SVR importance threshold.
        theta: random DoFs per iteration; None: the paper's for the method (rand 5, svr 10).
        keep_costed: a fix beyond the paper (row ``+costdofs``, ``FIXES``): the cost's DoFs
            always in C (``SelectionConfig.keep_costed``).
    """

    method: str = "svr-sum"
    rho: float = field(default=1.0, metadata={"at_least": 0.0})
    theta: int | None = field(default=None, metadata={"at_least": 0})
    keep_costed: bool = False

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"unknown method {self.method!r}; choose from {METHODS}")
        check_config(self)

    @property
    def config(self) -> SelectionConfig:
        """The DoF selector's config (theta None -> the paper's for the method)."""
        theta = paper_theta(self.method) if self.theta is None else self.theta
        return SelectionConfig(self.method, rho=float(self.rho), theta=int(theta),
                               keep_costed=bool(self.keep_costed))


@dataclass(frozen=True)
class PushScene:
    """The scene of a task that a seed builds (``SVRMPCSettings.build_task``).

    Attributes:
        problem: ``ours`` or ``authors`` (``PROBLEMS``): whose scenes the task builds.
        layouts: the folder of the authors' clutter scenes (``push_mcl_layouts``, one CSV per
            scene; seed i loads scene i); needed by problem ``authors`` on clutter only. A
            relative path is taken from the checkout's root (``dopt.lab.provenance.rooted``), as
            ``authors`` and ``preset`` record the folder they are given (relative to the
            current folder), so that a result names no folder of its machine.
        islands: MuJoCo's constraint islands (its default); False solves all constraints as
            one system (``mjDSBL_ISLAND``), as the authors' MuJoCo did, so that untouched
            objects' derivatives are tiny rather than exactly 0.
    """

    problem: str = field(default="ours", metadata={"choices": PROBLEMS})
    layouts: str | None = None
    islands: bool = True

    def __post_init__(self):
        check_config(self)
        if self.layouts is not None and not rooted(self.layouts).is_dir():
            raise ValueError(f"layouts: no folder {rooted(self.layouts)} (the authors' "
                             f"push_mcl_layouts, one CSV per scene)")


@dataclass(frozen=True)
class PushStart:
    """Where an episode starts and the first plan it optimises.

    Attributes:
        warm_start: start from the authors' set-up state and initial push plan
            (``dopt.tasks.push.warm_start``) instead of the task's start and zero controls.
        push_tail: the first push plan ends moving forward (``WarmStartConfig.moving_tail``);
            False: it ends braking at its end point, and MPC's padding pulls the pusher back.
    """

    warm_start: bool = False
    push_tail: bool = True

    def __post_init__(self):
        check_config(self)


@dataclass(frozen=True)
class Timing:
    """The clock: how long each optimisation lasts and so how many agent steps its plan lags.

    Attributes:
        clock: ``real``, ``virtual`` or ``model`` (``dopt.mpc``; the model clock's
            coefficients are the task's ``CLOCK_MODEL_MS``, fitted on this project's
            machine), or ``authors``: the model clock fitted to the authors' own times
            (``planners.svr_mpc.authors_clock``).
        nominal_threads: the thread count a virtual duration divides the CPU time by (2,
            this project's machine).
        clock_ms: on the model clock, every optimisation lasts this long (ms) instead of the
            task's fitted a + b |C| (``CLOCK_MODEL_MS``): every row then lags alike, so what
            is left between rows is their choice of DoFs, not their speed.
        slowdown: agent wall time per step over dt; None: the task's (the paper's).
        synchronous: the agent waits for the optimiser (deterministic; tests, debugging).
    """

    clock: str = field(default="real", metadata={"choices": SVR_CLOCKS})
    nominal_threads: float = field(default=2.0, metadata={"above": 0})
    clock_ms: float | None = field(default=None, metadata={"above": 0})
    slowdown: float | None = field(default=None, metadata={"above": 0})
    synchronous: bool = False

    def __post_init__(self):
        check_config(self)
        if self.synchronous and self.clock != "real":
            raise ValueError("synchronous runs have no clock: use clock='real' with it")
        if self.clock_ms is not None and self.clock != "model":
            raise ValueError(f"clock_ms sets the model clock's duration: use clock='model' "
                             f"with it, not {self.clock!r}")


@dataclass(frozen=True)
class Execution:
    """How the agent executes the optimised plans, and for how long.

    Attributes:
        executor: ``alg1`` (the paper's Alg. 1: pad with the last control, land shifted by
            the lag) or ``authors`` (their data generator's: hold after 80 controls, land at
            the nearest nominal state; ``dopt.mpc``).
        feedback: execute u + K (x - x_nominal) (the authors did not).
        control_noise: Gaussian noise on executed controls, fraction of each control's range.
        timeout: Y, agent steps; None: the task's (the paper's).
    """

    executor: str = field(default="alg1", metadata={"choices": EXECUTORS})
    feedback: bool = False
    control_noise: float = field(default=0.0, metadata={"at_least": 0.0,
                                                          "at_most": MAX_CONTROL_NOISE})
    timeout: int | None = field(default=None, metadata={"at_least": 1})

    def __post_init__(self):
        check_config(self)
