"""The MPC optimisers the pipeline runs, by name: the seam for a new one.

An optimiser is any object with ``optimise(state, plan) -> dopt.mpc.Plan``
(``dopt.mpc.Optimiser``). ``run_svr_mpc`` builds one per episode with a factory
``factory(context) -> optimiser``, given an ``OptimiserContext``: the task instance, its
scene, its cost, a rollout service over it (closed after the episode), the trial's
``SVRMPCSettings`` and the episode's own generator. ``OPTIMISERS`` maps names to factories;
``svr``, the paper's (``planners.svr.SVROptimiser``: iLQR on the DoF set of
``settings.selection``, the Table 1 rows baseline, rand, naive and SVR alike), is the default;
``unoptimised`` executes the task's first plan as it is (shifted and padded by the MPC loop),
the control that says what an optimiser adds to it.

``register_optimiser(name, factory)`` adds one; ``run_svr_mpc(settings, seed,
optimiser=name)`` (or a factory itself) runs it, and a trial's params name it ("optimiser",
absent for ``svr``, so the trials of the paper's rows keep their keys), so ``run_trial``, the
summaries and ``experiments/mpc.py --rows NAME`` (a row of its own, normalised by baseline)
run it too. A name is known to the processes that registered it; ``DOPT_OPTIMISERS`` (a
comma-separated list of modules, each registering its optimisers at import) makes it known to
every process that looks a name up, the command lines and the sweeps' spawned workers alike:

    DOPT_OPTIMISERS=my_optimisers python experiments/mpc.py --rows baseline,shooting ...

What the episode reads of an optimiser besides ``optimise``, where it has it:
``n_unstable_rollouts`` (line-search rollouts the stability verdict flagged) and, for
``run_svr_mpc(history=...)``, ``keep_history``, ``probe`` and ``history`` (as
``SVROptimiser``).
"""

from __future__ import annotations

import importlib
import os
import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from dopt.mpc import Plan
from dopt.rollout import RolloutService
from dopt.scene import Scene
from dopt.tasks.push.task_model import TaskModel
from planners.ilqr import ILQR
from planners.svr import METHODS, DofSelector, SVROptimiser

#: the default optimiser's name: the paper's iLQR-SVR (every Table 1 row)
DEFAULT_OPTIMISER = "svr"
#: what an optimiser's name may be: it ends trial keys and names a summary's row
NAME = re.compile(r"[a-z][a-z0-9_]*")
#: the environment variable naming the modules that register optimisers (comma-separated)
PLUGINS_ENV = "DOPT_OPTIMISERS"


@dataclass(frozen=True)
class OptimiserContext:
    """What a factory builds an episode's optimiser from: the task instance, its scene, the
    task's cost (``dopt.costs.QuadraticCost``: ``total(states, controls)``, ``derivatives``),
    a rollout service over the scene (``dopt.rollout.RolloutService``; the pipeline closes
    it after the episode), the trial's settings (a ``planners.svr_mpc.SVRMPCSettings``:
    ``selection``, ``ilqr``, ...; typed ``object`` here, since the settings module imports
    this one for the optimisers' names) and the episode's own generator (seeded by the
    trial's seed)."""

    task: TaskModel
    scene: Scene
    cost: object
    service: RolloutService
    settings: object
    rng: np.random.Generator


def svr_optimiser(context: OptimiserContext) -> SVROptimiser:
    """The paper's optimiser: one iLQR iteration (``settings.ilqr``: finite differences, key
    timesteps, box QP) on the DoF set a selector of ``settings.selection.config`` keeps."""
    c = context
    selector = DofSelector(c.scene.nv, c.task.robot_dofs, c.cost.costed_dofs,
                           c.settings.selection.config, c.rng)
    return SVROptimiser(ILQR(c.service, c.cost, c.settings.ilqr), selector)


class Unoptimised:
    """Returns the plan it is given, on no DoF; after its first, marked ``keep`` (nothing
    lands: ``dopt.mpc``): the episode executes its first plan (the push plan with
    ``warm_start``) as the executor runs any plan: Alg. 1 pads it with its last control for
    ever, the authors' executor holds the arm after min(80, T) of its controls."""

    def __init__(self):
        self.calls = 0

    def optimise(self, state: np.ndarray, plan: Plan) -> Plan:
        self.calls += 1
        return Plan(plan.controls, dofs=np.zeros(0, dtype=int),
                    info={"keep": True} if self.calls > 1 else {})


def unoptimised(context: OptimiserContext) -> Unoptimised:
    """The control row: no optimisation (what the MPC cost is without an optimiser)."""
    return Unoptimised()


OptimiserFactory = Callable[[OptimiserContext], object]
#: the optimisers by name (``register_optimiser`` adds one)
OPTIMISERS: dict[str, OptimiserFactory] = {DEFAULT_OPTIMISER: svr_optimiser,
                                           "unoptimised": unoptimised}


def register_optimiser(name: str, factory: OptimiserFactory, replace: bool = False) -> None:
    """Make ``factory(context) -> optimiser`` known as ``name`` (lower case letters, digits
    and _, starting with a letter; not a DoF-selection method's name); ``replace``: let it
    replace an optimiser registered under that name (never ``svr``)."""
    if not isinstance(name, str):
        raise TypeError(f"optimiser name must be a str, got {type(name).__name__}")
    if not NAME.fullmatch(name):
        raise ValueError(f"optimiser name {name!r} must be lower case letters, digits and _, "
                         f"starting with a letter")
    if name == DEFAULT_OPTIMISER or name in METHODS:
        raise ValueError(f"optimiser name {name!r} is taken: {DEFAULT_OPTIMISER!r} is the "
                         f"paper's and {', '.join(METHODS)} name its Table 1 rows")
    if name in OPTIMISERS and not replace:
        raise ValueError(f"an optimiser {name!r} is registered already (replace=True to "
                         f"replace it)")
    if not callable(factory):
        raise TypeError(f"optimiser factory must be callable (context -> optimiser), got "
                        f"{type(factory).__name__}")
    OPTIMISERS[name] = factory


def optimiser_names() -> tuple[str, ...]:
    """The names of ``OPTIMISERS``, once the modules of ``PLUGINS_ENV`` are imported (one
    that cannot be is a ValueError naming it)."""
    for module in filter(None, (m.strip() for m in os.environ.get(PLUGINS_ENV, "").split(","))):
        try:
            importlib.import_module(module)
        except ImportError as e:
            raise ValueError(f"{PLUGINS_ENV}: cannot import {module!r} ({e})") from e
    return tuple(OPTIMISERS)


def optimiser_factory(optimiser: str | OptimiserFactory) -> tuple[str, OptimiserFactory]:
    """(name, factory) of ``optimiser``: a name of ``OPTIMISERS`` (``optimiser_names``), or a
    factory itself (named by its ``__name__`` where that is a name ``NAME`` allows, else
    "custom")."""
    if isinstance(optimiser, str):
        if optimiser not in optimiser_names():
            raise ValueError(f"unknown optimiser {optimiser!r}; choose from "
                             f"{tuple(OPTIMISERS)} or register_optimiser one")
        return optimiser, OPTIMISERS[optimiser]
    if callable(optimiser):
        name = getattr(optimiser, "__name__", "")
        return (name if NAME.fullmatch(name) else "custom"), optimiser
    raise TypeError(f"optimiser must be a name of OPTIMISERS or a factory (context -> "
                    f"optimiser), got {type(optimiser).__name__}")
