"""The settings of one iLQR-SVR MPC trial (``SVRMPCSettings``: its groups are
``settings_groups``'), their flat form in a trial's params (``RECORD_NAMES``,
``SVRMPCSettings.params`` / ``from_params``), the one spelling of its derivative options
(``planners.ilqr.Derivatives``: ``spell_derivatives``), the paper's Table 1 rows by name
(``parse_row`` -> ``Row``), a task's own slowdown and timeout (``task_defaults``), and the
params and row label a trial is stored and reported under (``trial_params``,
``row_label``; its name: ``planners.svr_mpc.trial_names``)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields, is_dataclass, replace
from pathlib import Path
from typing import Literal

import mujoco

from dopt.lab.provenance import root_relative, rooted
from dopt.rollout import FDConfig
from dopt.tasks import build_push_task, get_task
from dopt.tasks.push.costs import COST_PRESETS
from dopt.tasks.push.task_model import TaskModel
from dopt.validation import check_config
from planners.ilqr import FINITE_DIFFERENCES, Derivatives, ILQRConfig
from planners.keypoints import KeypointConfig
from planners.svr_mpc.optimisers import DEFAULT_OPTIMISER, optimiser_names
from planners.svr_mpc.presets import (
    DEFAULT_ROW,
    PAPER,
    PROTOCOLS,
    TABLE1_ROWS,
    protocol_fields,
    row_fields,
)
from planners.svr_mpc.settings_groups import (
    DofSelection,
    Execution,
    PushScene,
    PushStart,
    Timing,
)

#: the protocols by name (``SVRMPCSettings.preset``; ``planners.svr_mpc.presets``)
PRESETS = tuple(PROTOCOLS)

#: the paper's cost per task where it is not Eq. 2 alone (``COST_PRESETS["paper"]``): their
#: push_soft task file adds a terminal reach residual (``presets.PAPER["cost"]``)
PAPER_COSTS = dict(PAPER["cost"].per_task)

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


#: the fixes beyond the paper a row can name (``sum-t10-r500+costdofs``): the setting each
#: sets, by its flat name (``SVRMPCSettings.params``: ``DofSelection.keep_costed``,
#: ``SVRMPCSettings.mu_reset``)
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
        """``settings`` with this row's method, theta and rho (its ``selection``), derivative
        variants (over the settings' own ``derivatives``) and fixes."""
        selection = replace(settings.selection, method=self.method, theta=self.theta,
                            rho=float(self.rho))
        return replace(settings, selection=selection,
                       derivatives=replace(settings.derivatives, **self.variants)
                       ).with_params(**self.fixes)


def parse_fixes(mods, what: str) -> dict:
    """The settings (flat names) a row's fixes (``FIXES``) set to True."""
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
    """One MPC trial's settings (the seed comes separately), in groups of one idea each
    (``planners.svr_mpc.settings_groups``: each group's Attributes say what its fields mean).

    A trial's params keep them flat (``params``, ``from_params``; ``trial_params``): every
    group's fields by their own names, the derivatives as ``Derivatives.fields()``.

    Attributes:
        task: a name of ``dopt.tasks.PUSH_TASKS`` (clutter, soft, soft_rigid).
        selection: which DoFs each optimisation keeps (``DofSelection``: method, rho, theta,
            keep_costed).
        derivatives: how iLQR differentiates the dynamics (``planners.ilqr.Derivatives``: the
            finite differences, default forward 1e-3, the authors' centred 1e-6; the
            timesteps they cover; the box-QP backward pass for the control limits).
        mu_reset: a fix beyond the paper (row ``+mureset``, ``FIXES``): mu reset at every MPC
            call (``ILQRConfig.mu_reset``).
        cost: a name of ``dopt.tasks.push.costs.COST_PRESETS``: ``ee`` (with the end-effector
            term, ours), ``paper`` (Eq. 2 alone) or ``paper-reach`` (Eq. 2 with the authors'
            soft-task reach residual).
        scene: the scene a seed builds (``PushScene``: problem, layouts, islands).
        start: where an episode starts (``PushStart``: warm_start, push_tail).
        timing: the clock (``Timing``: clock, nominal_threads, clock_ms, slowdown,
            synchronous).
        execution: how the agent executes the plans (``Execution``: executor, feedback,
            control_noise, timeout).
        threads: simulation threads (0: one per core).
    """

    task: str = "clutter"
    selection: DofSelection = DofSelection()
    derivatives: Derivatives = Derivatives()
    mu_reset: bool = False
    cost: str = field(default="ee", metadata={"choices": tuple(COST_PRESETS)})
    scene: PushScene = PushScene()
    start: PushStart = PushStart()
    timing: Timing = Timing()
    execution: Execution = Execution()
    threads: int = field(default=0, metadata={"at_least": 0})

    def __post_init__(self):
        get_task(self.task)                       # ValueError naming the known tasks
        for name, kind in GROUPS.items():
            if not isinstance(getattr(self, name), kind):
                raise TypeError(f"SVRMPCSettings.{name} must be a {kind.__name__}, got "
                                f"{getattr(self, name)!r}")
        # every field's type; the bounds and choices of the fields' metadata (the flags
        # derived from the fields read the same: dopt.lab.flags)
        check_config(self)
        scene = self.scene
        if scene.problem == "authors" and self.task == "clutter" and not scene.layouts:
            raise ValueError("problem 'authors' on clutter needs layouts: the folder of the "
                             "authors' scenes (push_mcl_layouts/{0..99}.csv)")
        if scene.layouts is not None and (scene.problem, self.task) != ("authors", "clutter"):
            raise ValueError(f"layouts: only the authors' clutter reads them (problem "
                             f"'authors', task 'clutter'), not problem {scene.problem!r} on "
                             f"{self.task}")

    def params(self) -> dict:
        """These settings flat, as a trial's params keep them (``RECORD_NAMES``, in that
        order): every group's fields by their names, the derivatives as
        ``Derivatives.fields()``; ``from_params`` reads them back."""
        flat: dict = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, Derivatives):
                flat.update(value.fields())
            elif f.name in GROUPS:
                flat.update(asdict(value))
            else:
                flat[f.name] = value
        return {name: flat[name] for name in RECORD_NAMES}

    @classmethod
    def from_params(cls, params: Mapping) -> SVRMPCSettings:
        """The settings of flat fields (``params``' names, ``RECORD_NAMES``; a missing one at
        its default, as in older trials' params): ``from_params(s.params()) == s``.

        Raises:
            TypeError: a name that is no setting (a trial's seed and optimiser are
                ``split_params``').
        """
        unknown = [k for k in params if k not in RECORD_PATHS]
        if unknown:
            raise TypeError(f"SVRMPCSettings has no setting {unknown[0]!r}; its settings: "
                            f"{', '.join(RECORD_NAMES)}")
        top: dict = {}
        for f in fields(cls):
            kind = GROUPS.get(f.name)
            if kind is Derivatives:
                top[f.name] = Derivatives.from_fields(params)
            elif kind is not None:
                top[f.name] = kind(**{g.name: params[g.name] for g in fields(kind)
                                      if g.name in params})
            elif f.name in params:
                top[f.name] = params[f.name]
        return cls(**top)

    def with_params(self, **changes) -> SVRMPCSettings:
        """These settings with ``changes``: a group whole (``timing=Timing(...)``) or a
        setting by its flat name (``params``: ``clock="model"``, ``fd_skip=5``, ``method=``),
        the groups first; TypeError naming one that is neither."""
        groups = {k: changes.pop(k) for k in list(changes) if k in GROUPS}
        base = replace(self, **groups) if groups else self
        return type(self).from_params({**base.params(), **changes}) if changes else base

    @classmethod
    def paper(cls, task: str, row: str = DEFAULT_ROW, **overrides) -> SVRMPCSettings:
        """The paper's protocol for ``row`` (a name of ``TABLE1_ROWS``) on ``task``
        (``planners.svr_mpc.presets.PAPER``, each number with its source): the authors' cost
        for the task (Eq. 2, on soft with their reach residual), their initial plan, 5 %
        control noise, the virtual clock. ``overrides``: as ``with_params`` takes them."""
        return cls(task=task).with_params(**{**row_fields(row),
                                             **protocol_fields("paper", task), **overrides})

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
        root (``dopt.lab.provenance.root_relative``). ``overrides``: as ``with_params``."""
        layouts = None if layouts is None else root_relative(layouts)
        return cls(task=task).with_params(**{**row_fields(row),
                                             **protocol_fields("authors", task),
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
        """The task instance of ``seed`` under these settings (``scene``: problem, layouts,
        islands): the same for every method, so costs pair up seed by seed."""
        scene = self.scene
        task = build_push_task(self.task, scene.problem, int(seed),
                               rooted(scene.layouts) if scene.layouts else None)
        if not scene.islands:
            task.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_ISLAND
        return task

    @property
    def ilqr(self) -> ILQRConfig:
        """iLQR's config: its derivatives (``derivatives``) and mu's reset."""
        return ILQRConfig(derivatives=self.derivatives, mu_reset=bool(self.mu_reset))


#: the groups of ``SVRMPCSettings`` by field name (the fields whose default is a dataclass)
GROUPS: dict[str, type] = {f.name: type(f.default) for f in fields(SVRMPCSettings)
                           if is_dataclass(f.default)}
#: the flat names of the settings, in the order a trial's params record them
#: (``SVRMPCSettings.params``; every committed trial's params keep this order)
RECORD_NAMES = ("task", "method", "rho", "theta", "slowdown", "timeout", "feedback",
                "control_noise", "synchronous", "threads", "cost", "warm_start", "clock",
                "nominal_threads", "fd_centered", "fd_eps", "keypoints", "fd_skip", "box_qp",
                "problem", "layouts", "islands", "push_tail", "clock_ms", "executor",
                "keep_costed", "mu_reset")


def _record_paths() -> dict[str, str]:
    """{flat name: the settings path (dotted) it sets}: a group's field under the group, the
    derivatives' flat fields under ``derivatives`` (fd_centered: its ``fd``)."""
    out = {}
    for f in fields(SVRMPCSettings):
        kind = GROUPS.get(f.name)
        if kind is Derivatives:
            out.update({name: f"{f.name}.{'fd' if name == 'fd_centered' else name}"
                        for name in Derivatives().fields()})
        elif kind is not None:
            out.update({g.name: f"{f.name}.{g.name}" for g in fields(kind)})
        else:
            out[f.name] = f.name
    return out


#: {flat name (``RECORD_NAMES``): the settings path it sets}
RECORD_PATHS = _record_paths()


def record_path(name: str, value) -> tuple[str, object]:
    """A setting named flat (a trial's params, a settings file: ``RECORD_PATHS``) as its
    dotted path and value (``fd_centered`` True/False: ``derivatives.fd`` central/forward);
    any other name (a path already, or no setting) as it is."""
    path = RECORD_PATHS.get(name, name)
    if name == "fd_centered" and isinstance(value, bool):
        value = "central" if value else "forward"
    return path, value


def task_defaults(task: str) -> tuple[float, int]:
    """The slowdown and timeout (agent steps) of ``task`` (its ``PushTaskSpec``; the paper's),
    what a trial's settings without them run with; builds no model."""
    spec = get_task(task)
    return float(spec.slowdown), int(spec.timeout)


def trial_params(settings: SVRMPCSettings, seed: int,
                 optimiser: str = DEFAULT_OPTIMISER) -> dict:
    """A trial's params (``dopt.lab.sweep``'s, what ``run_trial`` runs): the settings flat
    (``SVRMPCSettings.params``), "seed", and "optimiser" where it is not ``svr`` (a name of
    ``OPTIMISERS``)."""
    if not isinstance(settings, SVRMPCSettings):
        raise TypeError(f"settings must be SVRMPCSettings, got {type(settings).__name__}")
    if not isinstance(optimiser, str):
        raise TypeError(f"optimiser must be a name of OPTIMISERS (a trial's params are JSON), "
                        f"got {type(optimiser).__name__}")
    if optimiser not in optimiser_names():
        raise ValueError(f"unknown optimiser {optimiser!r}; choose from {optimiser_names()}")
    extra = {} if optimiser == DEFAULT_OPTIMISER else {"optimiser": optimiser}
    return {**settings.params(), "seed": seed, **extra}


def split_params(params: dict) -> tuple[SVRMPCSettings, int, str]:
    """A trial's params (``trial_params``) -> (its settings, ``SVRMPCSettings.from_params``;
    its seed; its optimiser's name)."""
    p = dict(params)
    seed, optimiser = p.pop("seed"), p.pop("optimiser", DEFAULT_OPTIMISER)
    return SVRMPCSettings.from_params(p), seed, optimiser


def row_label(p: dict) -> str:
    """Table row of a trial: ``row_name`` of its method, theta and rho (with another optimiser
    than ``svr``: its name, and ``:row_name`` unless the method is baseline), its
    ``derivatives_tag`` and ' +fb' when it executed the K feedback term."""
    name = row_name(p["method"], p["theta"], p["rho"])
    if (opt := p.get("optimiser", DEFAULT_OPTIMISER)) != DEFAULT_OPTIMISER:
        name = opt if p["method"] == "baseline" else f"{opt}:{name}"
    return name + derivatives_tag(p) + fixes_tag(p) + (" +fb" if p.get("feedback") else "")
