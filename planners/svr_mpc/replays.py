"""Which MPC trials keep their executed controls, for dopt-view's exact replay: a sweep's trial
function wrapped so that the trials of some seeds (or all) run with ``keep_controls=True``
(``run_trial``'s: the result holds the start state and the controls, ``CONTROLS_FIELDS``).
The key, and so the stored trial, is the same either way. The experiments keep those of the
first seed of each row by default (one replayable episode per row, the one their plots show)
and every trial's with ``--keep-controls``.

Not part of the code that computes a trial's result (``experiments/report_stale.py``): it only
chooses what a result keeps.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass


@dataclass(frozen=True)
class KeptControls:
    """``trial`` (a trial function ``(params, report, **options)`` with a ``keep_controls``
    option, e.g. ``run_trial``, ``CapturingTrial``'s ``trial``) run with
    ``keep_controls=True`` when ``every`` or the trial's seed is one of ``seeds``, without it
    otherwise; other options pass through. Picklable (by reference to ``trial``) for
    ``dopt.lab.sweep``'s pools and Ray."""

    trial: Callable
    seeds: tuple[int, ...] = ()
    every: bool = False

    def __post_init__(self):
        if not callable(self.trial):
            raise TypeError(f"trial must be callable, got {type(self.trial).__name__}")
        if not isinstance(self.every, bool):
            raise TypeError(f"every must be a bool, got {type(self.every).__name__}")
        object.__setattr__(self, "seeds", tuple(int(s) for s in self.seeds))

    def keeps(self, params: dict) -> bool:
        """Whether the trial of ``params`` keeps its controls."""
        return self.every or int(params.get("seed", -1)) in self.seeds

    def __call__(self, params: dict, report: Callable[[], None] | None = None,
                 **options) -> dict:
        if self.keeps(params):
            options["keep_controls"] = True
        return self.trial(params, report, **options)
