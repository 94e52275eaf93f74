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
  ``trial_aliases`` (``dopt.lab.sweep_store.Schema.aliases``); ``run_trial`` still labels an
  episode's blow-up captures by it (``legacy_trial_key`` says why).
- ``trial_identity``: what a stored record's params must give to stand for a trial
  (``Schema.identity``): the legacy key, as before the one identity (it spells every setting
  that changes a result, the threads and the layouts' folder name aside), so the check is as
  strong as it was.
"""

from __future__ import annotations

from dopt.lab.identity import trial_name
from planners.svr import paper_theta
from planners.svr_mpc.settings import SVRMPCSettings, row_name, trial_params
from planners.svr_mpc.settings import trial_key as settings_key
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
    changes its outcome as readable parts (timeout None, the task's own, is Y0; settings at
    their defaults add nothing). Only to find those trials, for ``trial_identity``, and as the
    label of an episode's blow-up captures (``run_trial``). Its one spelling is still
    ``planners.svr_mpc.settings.trial_key``: that file, like ``episode.py``, is one whose
    change marks every committed MPC result stale
    (``planners.svr_mpc.experiments.report_stale.SVR_COMPUTE_PATHS``), so the function moves
    here, and the captures to ``trial_key``, with the next change there."""
    return settings_key(p)


def trial_identity(p: dict) -> str:
    """What names a trial of params ``p`` for the sweeps' check (``Schema.identity``): its
    ``legacy_trial_key``, which spells what changes its outcome (not the threads)."""
    return legacy_trial_key(p)


def trial_aliases(p: dict) -> tuple[str, ...]:
    """The older name a trial of params ``p`` may be stored under (``legacy_trial_key``):
    the experiments' ``Schema.aliases``."""
    return (legacy_trial_key(p),)


__all__ = ["UNNAMED", "legacy_trial_key", "reference", "trial_aliases", "trial_identity",
           "trial_key"]
