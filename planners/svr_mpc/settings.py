"""The settings of one iLQR-SVR MPC trial (``SVRMPCSettings``), the one spelling of its
derivative options (``planners.ilqr.Derivatives``: ``spell_derivatives``), the paper's Table 1
rows by name (``parse_row`` -> ``Row``), a task's own slowdown and timeout
(``task_defaults``), and the params, key and row label a trial is stored and reported under
(``trial_params``, ``trial_key``, ``row_label``)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Literal

import mujoco

from dopt.lab.provenance import root_relative, rooted
from dopt.mpc import CLOCKS, EXECUTORS, MAX_CONTROL_NOISE
from dopt.rollout import FDConfig
from dopt.tasks import PUSH_PROBLEMS, build_push_task, get_task
from dopt.tasks.push.costs import COST_PRESETS
from dopt.tasks.push.task_model import TaskModel
from dopt.validation import check_config
from planners.ilqr import FINITE_DIFFERENCES, Derivatives, ILQRConfig
from planners.keypoints import KeypointConfig
from planners.svr import METHODS, SelectionConfig, paper_theta
from planners.svr_mpc.optimisers import DEFAULT_OPTIMISER, optimiser_names
from planners.svr_mpc.presets import (
    DEFAULT_ROW,
    PAPER,
    PROTOCOLS,
    TABLE1_ROWS,
    protocol_fields,
    row_fields,
)

#: the problems a trial can run on: ``ours`` (dopt's own scenes, ``dopt.tasks.PUSH_TASKS``) or
#: ``authors`` (the authors' scenes, objects and contacts, ``dopt.tasks.push.authors``)
PROBLEMS = PUSH_PROBLEMS

#: the protocols by name (``SVRMPCSettings.preset``; ``planners.svr_mpc.presets``)
PRESETS = tuple(PROTOCOLS)

#: the paper's cost per task where it is not Eq. 2 alone (``COST_PRESETS["paper"]``): their
#: push_soft task file adds a terminal reach residual (``presets.PAPER["cost"]``)
PAPER_COSTS = dict(PAPER["cost"].per_task)

#: the clocks a trial can run on: ``dopt.mpc.CLOCKS`` and ``authors``, the model clock fitted
#: to the authors' own optimisation times (``planners.svr_mpc.authors_clock``)
SVR_CLOCKS = CLOCKS + ("authors",)

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


#: the fixes beyond the paper a row can name (``sum-t10-r500+costdofs``): the
#: ``SVRMPCSettings`` field each sets (``SelectionConfig.keep_costed``, ``ILQRConfig.mu_reset``)
FIXES = {"costdofs": "keep_costed", "mureset": "mu_reset"}


def parse_variants(mods, what: str = "variants") -> dict:
    """The ``Derivatives`` fields that a row's derivative variants set: ``skip<K>`` or
    ``adaptive`` (key timesteps, ``planners.keypoints``), ``boxqp`` (the box-QP backward pass),
    ``central`` (the authors' central differences); ``what`` names them in errors."""
    over: dict = {}
    for mod in mods:
        if mod in FIXES:
            continue                                  # a fix, not a derivative variant
        if mod == "boxqp" and "box_qp" not in over:
            over["box_qp"] = True
        elif mod == "central" and "fd" not in over:
            over["fd"] = "central"
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


@dataclass(frozen=True)
class Row:
    """One row of a run (``parse_row``): the DoF-selection method, theta and rho of a Table 1
    row, the ``Derivatives`` fields its variants set (the run's flags give the others), and
    the optimiser that runs it (a name of ``OPTIMISERS``)."""

    method: str
    theta: int
    rho: float
    variants: dict = field(default_factory=dict)
    optimiser: str = DEFAULT_OPTIMISER
    fixes: dict = field(default_factory=dict)

    def apply(self, settings: SVRMPCSettings) -> SVRMPCSettings:
        """``settings`` with this row's method, theta, rho, derivative variants (over the
        settings' own derivatives) and fixes."""
        d = replace(settings.derivatives, **self.variants)
        return replace(settings, method=self.method, theta=self.theta, rho=float(self.rho),
                       **d.fields(), **self.fixes)


def parse_fixes(mods, what: str) -> dict:
    """The ``SVRMPCSettings`` fields a row's fixes (``FIXES``) set to True."""
    names = [m for m in mods if m in FIXES]
    if len(set(names)) < len(names):
        raise ValueError(f"{what}: a fix is repeated")
    return {FIXES[m]: True for m in names}


def parse_row(spec: str) -> Row:
    """A row of ``TABLE1_ROWS`` by name, or a registered optimiser's (``optimiser_names``; it
    runs with every DoF, as baseline), optionally with derivative variants (``parse_variants``):
    ``sum-t10-r1+skip5``, ``sum-t10-r1+adaptive``, ``sum-t10-r1+skip5+boxqp``,
    ``sum-t10-r1+central``; and fixes beyond the paper (``FIXES``): ``sum-t10-r500+costdofs``
    (the cost's DoFs always in C), ``sum-t10-r500+mureset`` (mu reset every MPC call)."""
    name, *mods = spec.split("+")
    if name in TABLE1_ROWS:
        return Row(*TABLE1_ROWS[name], parse_variants(mods, f"row {spec!r}"),
                   fixes=parse_fixes(mods, f"row {spec!r}"))
    names = optimiser_names()
    if name in names and name != DEFAULT_OPTIMISER:
        return Row("baseline", 0, 1.0, parse_variants(mods, f"row {spec!r}"), name)
    extra = [o for o in names if o != DEFAULT_OPTIMISER]
    raise ValueError(f"unknown Table 1 row {name!r}: choose from {', '.join(TABLE1_ROWS)}"
                     + (f", or an optimiser: {', '.join(extra)}" if extra else ""))


def spell_derivatives(d: Derivatives, form: Literal["key", "label", "row"]) -> tuple[str, ...]:
    """The words naming where ``d`` departs from the default (forward eps 1e-3 at every
    timestep, a plain backward pass), in the one order fd, keypoints, box QP: the spelling of
    the derivative options everywhere they are written out.

    form: ``key`` (``trial_key``'s parts: ``fdc1e-06`` or ``fdf<eps>``, ``skip<K>`` or
    ``kpadaptive``, ``boxqp``), ``label`` (``row_label``'s ``+`` suffixes: ``central`` or
    ``fd<eps>``, ``skip<K>`` for K > 1 or ``adaptive``, ``boxqp``) or ``row`` (the variants a
    row names, ``parse_variants``' words: ``central``, ``skip<K>`` or ``adaptive``,
    ``boxqp``; ValueError for a step no row can name).
    """
    fd, words = d.fd_config, []
    if fd != FDConfig():
        if form == "key":
            words.append(f"fd{'c' if fd.centered else 'f'}{fd.eps:g}")
        elif fd.centered and (form == "label" or d.fd_eps is None):
            words.append("central")
        elif form == "label":
            words.append(f"fd{fd.eps:g}")
        else:
            raise ValueError(f"no row variant names finite differences of eps {fd.eps:g} "
                             f"({'central' if fd.centered else 'forward'}): a row names "
                             f"{', '.join(FINITE_DIFFERENCES)} at their own steps")
    if d.keypoints == "adaptive":
        words.append("kpadaptive" if form == "key" else "adaptive")
    elif d.keypoints == "skip" and (form != "label" or d.fd_skip > 1):
        words.append(f"skip{d.fd_skip}")
    if d.box_qp:
        words.append("boxqp")
    return tuple(words)


def derivatives_tag(p: dict) -> str:
    """The derivative options of a trial's params as a row-label suffix
    (``spell_derivatives``' labels): `` +central``, `` +skip<K>`` or `` +adaptive``,
    `` +boxqp``; '' for the defaults."""
    return "".join(f" +{w}" for w in spell_derivatives(Derivatives.from_fields(p), "label"))


def fixes_tag(p: dict) -> str:
    """The fixes beyond the paper (``FIXES``) of a trial's params as a row-label suffix:
    `` +costdofs``, `` +mureset``; '' for the paper's rule."""
    return "".join(f" +{name}" for name, f in FIXES.items() if p.get(f))


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
        clock: ``real``, ``virtual`` or ``model`` (``dopt.mpc``; the model clock's
            coefficients are the task's ``CLOCK_MODEL_MS``, fitted on this project's
            machine), or ``authors``: the model clock fitted to the authors' own times
            (``planners.svr_mpc.authors_clock``).
        nominal_threads: the thread count a virtual duration divides the CPU time by (2,
            this project's machine).
        fd_centered, fd_eps: the finite differences (default forward 1e-3; the authors:
            centred 1e-6).
        keypoints, fd_skip: the timesteps the finite differences cover (``every``, ``skip``
            every fd_skip-th, ``adaptive``; ``planners.keypoints``), A and B linear between.
        box_qp: control limits in the backward pass. The five are ``derivatives``
            (``planners.ilqr.Derivatives``) spelled flat, as a trial's params keep them; set
            them together: ``replace(settings, **Derivatives(...).fields())``.
        problem: ``ours`` or ``authors`` (``PROBLEMS``): whose scenes the task builds.
        layouts: the folder of the authors' clutter scenes (``push_mcl_layouts``, one CSV per
            scene; seed i loads scene i); needed by problem ``authors`` on clutter only. A
            relative path is taken from the checkout's root (``dopt.lab.provenance.rooted``), as
            ``authors`` and ``preset`` record the folder they are given (relative to the
            current folder), so that a result names no folder of its machine.
        islands: MuJoCo's constraint islands (its default); False solves all constraints as
            one system (``mjDSBL_ISLAND``), as the authors' MuJoCo did, so that untouched
            objects' derivatives are tiny rather than exactly 0.
        push_tail: the first push plan ends moving forward (``WarmStartConfig.moving_tail``);
            False: it ends braking at its end point, and MPC's padding pulls the pusher back.
        clock_ms: on the model clock, every optimisation lasts this long (ms) instead of the
            task's fitted a + b |C| (``CLOCK_MODEL_MS``): every row then lags alike, so what
            is left between rows is their choice of DoFs, not their speed.
        executor: ``alg1`` (the paper's Alg. 1: pad with the last control, land shifted by
            the lag) or ``authors`` (their data generator's: hold after 80 controls, land at
            the nearest nominal state; ``dopt.mpc``).
        keep_costed, mu_reset: fixes beyond the paper (rows ``+costdofs``, ``+mureset``,
            ``FIXES``): the cost's DoFs always in C (``SelectionConfig.keep_costed``); mu reset
            at every MPC call (``ILQRConfig.mu_reset``).
    """

    task: str = "clutter"
    method: str = "svr-sum"
    rho: float = field(default=1.0, metadata={"at_least": 0.0})
    theta: int | None = field(default=None, metadata={"at_least": 0})
    slowdown: float | None = field(default=None, metadata={"above": 0})
    timeout: int | None = field(default=None, metadata={"at_least": 1})
    feedback: bool = False
    control_noise: float = field(default=0.0, metadata={"at_least": 0.0,
                                                          "at_most": MAX_CONTROL_NOISE})
    synchronous: bool = False
    threads: int = field(default=0, metadata={"at_least": 0})
    cost: str = field(default="ee", metadata={"choices": tuple(COST_PRESETS)})
    warm_start: bool = False
    clock: str = field(default="real", metadata={"choices": SVR_CLOCKS})
    nominal_threads: float = field(default=2.0, metadata={"above": 0})
    fd_centered: bool = False
    fd_eps: float = field(default=1e-3, metadata={"above": 0})
    keypoints: str = "every"
    fd_skip: int = field(default=1, metadata={"at_least": 1})
    box_qp: bool = False
    problem: str = field(default="ours", metadata={"choices": PROBLEMS})
    layouts: str | None = None
    islands: bool = True
    push_tail: bool = True
    clock_ms: float | None = field(default=None, metadata={"above": 0})
    executor: str = field(default="alg1", metadata={"choices": EXECUTORS})
    keep_costed: bool = False
    mu_reset: bool = False

    def __post_init__(self):
        get_task(self.task)                       # ValueError naming the known tasks
        if self.method not in METHODS:
            raise ValueError(f"unknown method {self.method!r}; choose from {METHODS}")
        # every field's type; the bounds and choices of the fields' metadata (the flags
        # derived from the fields read the same: dopt.lab.flags)
        check_config(self)
        if self.problem == "authors" and self.task == "clutter" and not self.layouts:
            raise ValueError("problem 'authors' on clutter needs layouts: the folder of the "
                             "authors' scenes (push_mcl_layouts/{0..99}.csv)")
        if self.layouts is not None and not rooted(self.layouts).is_dir():
            raise ValueError(f"layouts: no folder {rooted(self.layouts)} (the authors' "
                             f"push_mcl_layouts, one CSV per scene)")
        if self.layouts is not None and (self.problem, self.task) != ("authors", "clutter"):
            raise ValueError(f"layouts: only the authors' clutter reads them (problem "
                             f"'authors', task 'clutter'), not problem {self.problem!r} on "
                             f"{self.task}")
        _ = self.ilqr                  # ValueError naming a bad keypoint method or fd_skip
        if self.synchronous and self.clock != "real":
            raise ValueError("synchronous runs have no clock: use clock='real' with it")
        if self.clock_ms is not None and self.clock != "model":
            raise ValueError(f"clock_ms sets the model clock's duration: use clock='model' "
                             f"with it, not {self.clock!r}")

    @classmethod
    def paper(cls, task: str, row: str = DEFAULT_ROW, **overrides) -> SVRMPCSettings:
        """The paper's protocol for ``row`` (a name of ``TABLE1_ROWS``) on ``task``
        (``planners.svr_mpc.presets.PAPER``, each number with its source): the authors' cost
        for the task (Eq. 2, on soft with their reach residual), their initial plan, 5 %
        control noise, the virtual clock."""
        return cls(**{"task": task, **row_fields(row), **protocol_fields("paper", task),
                      **overrides})

    @classmethod
    def authors(cls, task: str, row: str = DEFAULT_ROW, layouts: str | Path | None = None,
                **overrides) -> SVRMPCSettings:
        """The authors' regime for ``row`` on their own problem ``task``
        (``planners.svr_mpc.presets.AUTHORS`` over ``PAPER``, each number with its source):
        their scenes (clutter: scene ``seed`` of ``layouts``), objects and contacts, their
        cost weights without a control cost (``dopt.tasks.push.costs.AUTHORS_COSTS``), their
        initial plan, no control noise, their data generator's executor (``authors``: hold
        after 80 controls, nearest-state landing) and the clock fitted to their times
        (``authors``). Where the paper's text (Alg. 1) and their code differ, this follows
        the code, which generated their data; ``executor="alg1"`` is the text's reading.
        ``layouts`` (relative to the current folder) is recorded relative to the checkout's
        root (``dopt.lab.provenance.root_relative``)."""
        layouts = None if layouts is None else root_relative(layouts)
        return cls(**{"task": task, **row_fields(row), **protocol_fields("authors", task),
                      "layouts": layouts, **overrides})

    @classmethod
    def preset(cls, task: str, *, protocol: str = "ours",
               layouts: str | Path | None = None) -> SVRMPCSettings:
        """The settings the experiments run by default on ``task`` under ``protocol``
        (``PRESETS``), as ``PickPlaceSettings.preset(task, goal, protocol=)``: ``ours`` (the
        defaults), ``paper`` (``paper``, its default row) or ``authors`` (``authors``, with
        ``layouts``; only the authors' problem reads them: ValueError with another)."""
        name = protocol
        if layouts is not None and name != "authors":
            raise ValueError(f"layouts are the authors' clutter scenes: only preset 'authors' "
                             f"reads them, not {name!r}")
        if name not in PROTOCOLS:
            raise ValueError(f"unknown preset {name!r}; choose from {PRESETS}")
        if name == "authors":
            return cls.authors(task, layouts=layouts)
        if name == "paper":
            return cls.paper(task)
        return cls(task=task)

    def build_task(self, seed: int) -> TaskModel:
        """The task instance of ``seed`` under these settings (``problem``, ``layouts``,
        ``islands``): the same for every method, so costs pair up seed by seed."""
        task = build_push_task(self.task, self.problem, int(seed),
                               rooted(self.layouts) if self.layouts else None)
        if not self.islands:
            task.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_ISLAND
        return task

    @property
    def derivatives(self) -> Derivatives:
        """The five derivative fields as one typed value (``Derivatives.from_fields``)."""
        return Derivatives.from_fields({k: getattr(self, k) for k in Derivatives().fields()})

    @property
    def ilqr(self) -> ILQRConfig:
        """iLQR's config: its derivatives (``derivatives``) and mu's reset."""
        return ILQRConfig(derivatives=self.derivatives, mu_reset=bool(self.mu_reset))

    @property
    def selection(self) -> SelectionConfig:
        """The DoF selector's config (theta None -> the paper's for the method)."""
        theta = paper_theta(self.method) if self.theta is None else self.theta
        return SelectionConfig(self.method, rho=float(self.rho), theta=int(theta),
                               keep_costed=bool(self.keep_costed))


def task_defaults(task: str) -> tuple[float, int]:
    """The slowdown and timeout (agent steps) of ``task`` (its ``PushTaskSpec``; the paper's),
    what a trial's settings without them run with; builds no model."""
    spec = get_task(task)
    return float(spec.slowdown), int(spec.timeout)


def trial_params(settings: SVRMPCSettings, seed: int,
                 optimiser: str = DEFAULT_OPTIMISER) -> dict:
    """A trial's params (``dopt.lab.sweep``'s, what ``run_trial`` runs): every ``SVRMPCSettings``
    field, "seed", and "optimiser" where it is not ``svr`` (a name of ``OPTIMISERS``)."""
    if not isinstance(settings, SVRMPCSettings):
        raise TypeError(f"settings must be SVRMPCSettings, got {type(settings).__name__}")
    if not isinstance(optimiser, str):
        raise TypeError(f"optimiser must be a name of OPTIMISERS (a trial's params are JSON), "
                        f"got {type(optimiser).__name__}")
    if optimiser not in optimiser_names():
        raise ValueError(f"unknown optimiser {optimiser!r}; choose from {optimiser_names()}")
    extra = {} if optimiser == DEFAULT_OPTIMISER else {"optimiser": optimiser}
    return {**asdict(settings), "seed": seed, **extra}


def split_params(params: dict) -> tuple[SVRMPCSettings, int, str]:
    """A trial's params (``trial_params``) -> (its settings, its seed, its optimiser's name)."""
    p = dict(params)
    seed, optimiser = p.pop("seed"), p.pop("optimiser", DEFAULT_OPTIMISER)
    return SVRMPCSettings(**p), seed, optimiser


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
    if p.get("clock", "real") == "authors":
        parts.append("clockauthors")
    elif p.get("clock", "real") != "real":
        parts.append(f"clock{p['clock']}{p.get('nominal_threads', 2.0):g}")
    if p.get("executor", "alg1") != "alg1":
        parts.append(f"exec{p['executor']}")
    if p.get("clock_ms") is not None:
        parts.append(f"ms{p['clock_ms']:g}")
    if p.get("synchronous"):
        parts.append("sync")
    parts += spell_derivatives(Derivatives.from_fields(p), "key")
    if p.get("problem", "ours") != "ours":
        parts.append(p["problem"])
    if not p.get("islands", True):
        parts.append("noislands")
    if not p.get("push_tail", True):
        parts.append("notail")
    parts += [f"fix{name}" for name, f in FIXES.items() if p.get(f)]
    if p.get("optimiser", DEFAULT_OPTIMISER) != DEFAULT_OPTIMISER:
        parts.append(f"opt{p['optimiser']}")
    return "-".join(parts)


def row_label(p: dict) -> str:
    """Table row of a trial: ``row_name`` of its method, theta and rho (with another optimiser
    than ``svr``: its name, and ``:row_name`` unless the method is baseline), its
    ``derivatives_tag`` and ' +fb' when it executed the K feedback term."""
    name = row_name(p["method"], p["theta"], p["rho"])
    if (opt := p.get("optimiser", DEFAULT_OPTIMISER)) != DEFAULT_OPTIMISER:
        name = opt if p["method"] == "baseline" else f"{opt}:{name}"
    return name + derivatives_tag(p) + fixes_tag(p) + (" +fb" if p.get("feedback") else "")
