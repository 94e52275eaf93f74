"""The names and the identity of a pick-and-place trial (``dopt.lab.identity``, the rule both
papers name trials by).

- ``trial_key(label, seed, settings)``: ``<label>-seed<seed>-<8 hex>``, the hex hashing the
  settings that change the trial's result (``PickPlaceSettings.identity``: not the threads;
  what the presets and the picker resolve to today) where they differ from a fixed reference,
  ``reference(task)``: the dataclass field defaults of ``PickPlaceSettings`` and of its
  sub-configs (CEM, the task's scene config, the picker, the stability bounds), never a
  preset. The label is the method (Fig. 7, the scaling and encoding sweeps) or the goal (the
  Panda's replays). A setting added later with its default value keeps every name.
- ``legacy_trial_key``: the names of the trials written before the one identity
  (``<method>-seed<seed>-<sha1 of the full identity>``, which changed with any new field);
  the committed trials under docs/results/runs keep them, and a sweep finds them there
  through ``trial_aliases`` (``dopt.lab.sweep_store.Schema.aliases``).
- ``trial_identity``: what a stored record's params must give to stand for a trial
  (``Schema.identity``): the method, the seed and the full ``PickPlaceSettings.identity``,
  as the legacy key hashed them, so the check is as strong as before.
"""

from __future__ import annotations

import hashlib
import json

from dopt.lab.identity import field_defaults, trial_name
from dopt.stability import StabilityBounds
from dopt.tasks.pick.picker import PickerConfig
from planners.cem import CEMConfig
from planners.pick_place.settings import PickPlaceSettings, check_settings
from planners.pick_place.tasks import pick_task


def reference(task: str) -> dict:
    """The fixed reference a ``task`` trial's settings are named against (shaped as
    ``PickPlaceSettings.identity``): the field defaults of ``PickPlaceSettings`` (its required
    fields, task, goal, n, bound, have none: always named), of ``CEMConfig`` under "cem", and
    under "resolved" of the task's scene config class, ``PickerConfig`` and
    ``StabilityBounds``. It moves only when those classes' code does."""
    return {**field_defaults(PickPlaceSettings), "cem": field_defaults(CEMConfig),
            "resolved": {"scene": field_defaults(pick_task(task).config),
                         "picker": field_defaults(PickerConfig),
                         "stability": field_defaults(StabilityBounds)}}


def trial_key(label: str, seed: int, settings: PickPlaceSettings) -> str:
    """A trial's name, ``<label>-seed<seed>-<8 hex>`` (``dopt.lab.identity.trial_name`` of
    ``settings.identity()`` against ``reference(settings.task)``). The sweeps key their trial
    files by it (label: the method; the Panda's: the goal), and ``run_trial`` its blow-up
    captures."""
    check_settings(settings)
    return trial_name(label, seed, settings.identity(), reference(settings.task))


def legacy_trial_key(method: str, seed: int, settings: PickPlaceSettings) -> str:
    """The name of a trial written before the one identity: <method>-seed<seed>-<the first
    eight hex of the SHA-1 of the full ``settings.identity()``>. Only to find those trials."""
    check_settings(settings)
    digest = hashlib.sha1(json.dumps(settings.identity(), sort_keys=True).encode()
                          ).hexdigest()[:8]
    return f"{method}-seed{seed}-{digest}"


def trial_identity(params: dict) -> dict:
    """What names a sweep's trial of ``params`` ({"settings", "method", "seed"}, as
    ``run_trial`` takes them): its method, seed and ``PickPlaceSettings.identity`` (the
    settings that change its result, not the threads). The experiments'
    ``dopt.lab.sweep.Schema.identity``: a stored record whose params give another is another
    trial's.

    Raises:
        KeyError, TypeError, ValueError: ``params`` are not a trial's."""
    return {"method": params["method"], "seed": int(params["seed"]),
            "settings": PickPlaceSettings.from_dict(params["settings"]).identity()}


def trial_aliases(params: dict) -> tuple[str, ...]:
    """The older name a sweep's trial of ``params`` may be stored under (``legacy_trial_key``):
    the experiments' ``dopt.lab.sweep.Schema.aliases``."""
    return (legacy_trial_key(params["method"], int(params["seed"]),
                             PickPlaceSettings.from_dict(params["settings"])),)


__all__ = ["legacy_trial_key", "reference", "trial_aliases", "trial_identity", "trial_key"]
