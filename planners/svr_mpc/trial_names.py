"""The name and the identity of an iLQR-SVR MPC trial (``dopt.lab.identity``, the rule both
papers name trials by).

- ``trial_key(p)`` of a trial's params (``trial_params``: flat, the record's form):
  ``<task>-<row>-seed<seed>-<8 hex>`` (the row: ``row_name`` of its method, theta and rho),
  the hex hashing the params, but the seed and the thread count
  (``planners.trial_progress.RUN_ONLY_SETTINGS``), that differ from ``reference(task)``: the
  flat params of ``SVRMPCSettings(task=task)`` with the default optimiser, the dataclass's
  field defaults, never a protocol's preset. A setting added later with its default keeps
  every name.
- ``legacy_trial_key``: the names of the trials written before the one identity, a chain of
  readable parts (``clutter-svr-sum-rho1-theta10-slow1-Y0-seed0-fb-...``); the committed
  trials under docs/results/runs keep them, and a sweep finds them there through
  ``trial_aliases`` (``dopt.lab.sweep_store.Schema.aliases``).
- ``trial_identity``: what a stored record's params must give to stand for a trial
  (``Schema.identity``): the legacy key (it spells every setting of ``LEGACY_NAMES`` that
  changes a result, the threads and the layouts' folder name aside) and the settings added
  since that differ from their defaults (``unspelled``).
"""

from __future__ import annotations

from dopt.lab.identity import changed_settings, trial_name
from planners.ilqr import Derivatives
from planners.svr import paper_theta
from planners.svr_mpc.optimisers import DEFAULT_OPTIMISER
from planners.svr_mpc.settings import (
    FIXES,
    SVRMPCSettings,
    row_name,
    spell_derivatives,
    trial_params,
)
from planners.trial_progress import RUN_ONLY_SETTINGS

#: the params a trial's name leaves out: its seed (written apart) and the run-only settings
UNNAMED = ("seed", *RUN_ONLY_SETTINGS)


def reference(task: str) -> dict:
    """The fixed reference a ``task`` trial's params are named against: ``trial_params`` of
    ``SVRMPCSettings(task=task)`` (its field defaults; the default optimiser) without
    ``UNNAMED``."""
    p = trial_params(SVRMPCSettings(task=task), 0)
    return {k: v for k, v in p.items() if k not in UNNAMED}


def trial_key(p: dict) -> str:
    """A trial's name from its params (``trial_params``): ``<task>-<row>-seed<seed>-<8 hex>``
    (``dopt.lab.identity.trial_name`` of the params but ``UNNAMED`` against
    ``reference(task)``). The sweeps key their trial files by it.

    Raises:
        TypeError, ValueError, KeyError: ``p`` are not a trial's params."""
    if not isinstance(p, dict):
        raise TypeError(f"a trial's params must be a dict, got {type(p).__name__}")
    theta = paper_theta(p["method"]) if p.get("theta") is None else p["theta"]
    label = f"{p['task']}-{row_name(p['method'], theta, p['rho'])}"
    values = {k: v for k, v in p.items() if k not in UNNAMED}
    return trial_name(label, p["seed"], values, reference(p["task"]))


def legacy_trial_key(p: dict) -> str:
    """The name of a trial written before the one identity, from its params: everything that
    changed its outcome then as readable parts (timeout None, the task's own, is Y0; settings
    at their defaults add nothing). Only to find those trials (``trial_aliases``) and to check
    them (``trial_identity``); a setting added since (not in ``LEGACY_NAMES``) is not spelled
    here, and a trial that sets one has no legacy name."""
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


#: the params a ``legacy_trial_key`` knows (the flat settings when the one identity came, and
#: the optimiser): a trial whose params set another has no legacy name
LEGACY_NAMES = frozenset((
    "task", "method", "rho", "theta", "slowdown", "timeout", "feedback", "control_noise",
    "synchronous", "threads", "cost", "warm_start", "clock", "nominal_threads", "fd_centered",
    "fd_eps", "keypoints", "fd_skip", "box_qp", "problem", "layouts", "islands", "push_tail",
    "clock_ms", "executor", "keep_costed", "mu_reset", "seed", "optimiser"))


def unspelled(p: dict) -> dict:
    """The settings of params ``p`` that ``legacy_trial_key`` cannot spell: those outside
    ``LEGACY_NAMES`` that differ from ``reference(task)`` (``changed_settings``)."""
    values = {k: v for k, v in p.items() if k not in LEGACY_NAMES}
    return changed_settings(values, reference(p["task"]))


def trial_identity(p: dict) -> list:
    """What names a trial of params ``p`` for the sweeps' check (``Schema.identity``): its
    ``legacy_trial_key``, which spells what changes its outcome (not the threads, not the
    layouts' folder), and the settings it cannot spell (``unspelled``), so that a setting
    added later is compared too."""
    return [legacy_trial_key(p), unspelled(p)]


def trial_aliases(p: dict) -> tuple[str, ...]:
    """The older name a trial of params ``p`` may be stored under (``legacy_trial_key``),
    none when ``p`` sets a setting that name cannot spell (``unspelled``): the experiments'
    ``Schema.aliases``."""
    return () if unspelled(p) else (legacy_trial_key(p),)


__all__ = ["UNNAMED", "legacy_trial_key", "reference", "trial_aliases", "trial_identity",
           "trial_key"]
