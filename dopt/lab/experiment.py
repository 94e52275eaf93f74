"""The experiment protocol: one registered object per kind of result file, the report's hooks.

A result file (``docs/results/*.json``) names its kind in its "experiment" field (a benchmark's
file in its "bench" field, ``Experiment.benches``). An ``Experiment`` is everything the report
engine (``dopt.lab.report``) knows of one kind: the paper it belongs to, the script that writes
it, and hooks, each with a default that does nothing, for its RESULTS.md section, its headline,
the paper items it reproduces (``catalogue``), its rows of the README's map (``map_rows``), the
paper's claims it judges (``claims``), its staleness findings (``stale``), the rebuild of its
summary from its trials (``rebuild``, ``experiments/resummarize.py``) and which committed trials
it holds (``trial_files``). The engine loops over ``registered()`` and never names a kind.

Registration: ``register_experiment(obj)``; ``registered()`` imports, once, every module named
by the entry-point group ``dopt.experiments`` (pyproject.toml; the paper slices'
``planners.<slice>.experiments.registry``), by the ``DOPT_EXPERIMENTS`` environment variable
(comma-separated module names) and, where the installed distribution has no such entry points
(an install older than the group), the two slices' registry modules. A paper's page
(docs/KEY-PARTICLES.md, ...) is registered with ``register_page``. The lab imports no planner:
modules are found by name.
"""

from __future__ import annotations

import importlib
import logging
import os
from pathlib import Path
from typing import Any

from dopt.lab.trialpack import StoredTrial, stored_trials

#: a result file (``dopt.lab.report.base.Result``: ``path``, ``kind``, ``data``, ...) and the
#: committed trials of one (``dopt.lab.report.trials.TrialInfo``): the report's types, named
#: here only, so that the protocol imports nothing of the engine
Result = Any
TrialInfo = Any

log = logging.getLogger(__name__)

#: the entry-point group of the modules that register experiments
ENTRY_POINTS = "dopt.experiments"
#: the environment variable naming more such modules (comma-separated)
ENV = "DOPT_EXPERIMENTS"
#: the paper slices' registry modules, loaded when the installed distribution has no entry
#: points of the group (they are named, never imported here: the lab imports no planner)
BUILT_IN = ("planners.pick_place.experiments.registry", "planners.svr_mpc.experiments.registry")

_EXPERIMENTS: list[Experiment] = []
_PAGES: dict[str, Any] = {}
_loaded: list[bool] = []


class Experiment:
    """One kind of result file and the report's hooks for it (subclass and override).

    Attributes:
        kind: the result files' "experiment" field.
        paper: the paper it reproduces (a registered page's paper), "" for a measurement
            behind both or neither.
        script: the command that writes it.
        benches: the "bench" field values of benchmark files of this kind (they have no
            "experiment" field).
        rank: where its section sits on RESULTS.md (lower first; equal ranks in registration
            order).
        trial_fields: the summary fields its trials give (``rebuild`` computes them again).
    """

    kind: str = ""
    paper: str = ""
    script: str = ""
    benches: tuple[str, ...] = ()
    rank: float = 1000.0
    trial_fields: tuple[str, ...] = ()

    def owns(self, result: Result) -> bool:
        """Whether ``result`` is a file of this experiment."""
        return result.kind == self.kind

    # ------------------------------------------------------------------ RESULTS.md
    def section(self, results: list[Result], page: Path) -> list[str]:
        """Its section of RESULTS.md (lines) over its files ``results`` (none: no section)."""
        return []

    def headline(self, result: Result) -> str | None:
        """One line of what ``result`` came to (None: this kind has no headline)."""
        return None

    def catalogue(self) -> list:
        """The paper items it reproduces (``dopt.lab.report.engine.Entry`` rows)."""
        return []

    def departure(self, result: Result) -> str:
        """How ``result`` departs from its protocol ("" when it does not): such a file is
        left out of the headlines and the map, shown in its section beside the protocol's."""
        return ""

    def headline_intro(self, results: list[Result]) -> str:
        """A sentence the headlines' introduction adds ("" for none)."""
        return ""

    def headline_notes(self, results: list[Result], page: Path) -> list[str]:
        """Lines after the headline table (its claims on the files, ...)."""
        return []

    def beside(self, results: list[Result], page: Path) -> list[str]:
        """A section after every kind's own (its files beside the paper's)."""
        return []

    def in_progress(self, results_dir: Path, results: list[Result]) -> list[str]:
        """A section of its sweeps whose summary is not recorded yet."""
        return []

    # ------------------------------------------------------------- README, papers
    def map_rows(self) -> list:
        """Its rows of README's map (``dopt.lab.report.map.MapRow``)."""
        return []

    def claims(self) -> list:
        """The paper's claims its files judge (``dopt.lab.report.claims.Claim``)."""
        return []

    # ------------------------------------------------------------ trials, staleness
    def trial_files(self, folder: Path, result: Result) -> list[StoredTrial]:
        """The committed trials under the sweep ``folder`` that ``result`` holds (default:
        ``own_trials``)."""
        return own_trials(folder, result)

    def stale(self, result: Result, results_dir: Path, trials: TrialInfo | None
              ) -> list[str] | None:
        """What in ``result`` today's code no longer gives (one sentence each; [] when
        current; None where it cannot be checked)."""
        return []

    def rebuild(self, data: dict, records: list[dict], info: TrialInfo) -> dict | None:
        """Its ``trial_fields`` computed again from its trial records (None: no rebuild)."""
        return None


def own_trials(folder: Path, r: Result) -> list[StoredTrial]:
    """The trials under ``folder``/trials (loose files and packed records,
    ``dopt.lab.trialpack``) that summary ``r`` holds: those its "trial_keys" names (a run that
    shares its folder with others), else all of them."""
    files = stored_trials(Path(folder) / "trials")
    if isinstance(r.data.get("trial_keys"), list):
        keys = set(r.data["trial_keys"])
        return [p for p in files if p.stem in keys]
    return files


def register_experiment(experiment: Experiment) -> Experiment:
    """Register ``experiment`` (TypeError unless an ``Experiment`` with a kind; ValueError on
    a kind registered already); returns it."""
    if not isinstance(experiment, Experiment):
        raise TypeError(f"expected an Experiment, got {type(experiment).__name__}")
    if not isinstance(experiment.kind, str) or not experiment.kind:
        raise ValueError(f"{type(experiment).__name__}: kind must be a non-empty string")
    if any(e.kind == experiment.kind for e in _EXPERIMENTS):
        raise ValueError(f"experiment kind {experiment.kind!r} is registered already")
    _EXPERIMENTS.append(experiment)
    return experiment


def unregister_experiment(kind: str) -> None:
    """Remove the experiment of ``kind`` (ValueError when none is registered)."""
    for i, e in enumerate(_EXPERIMENTS):
        if e.kind == kind:
            del _EXPERIMENTS[i]
            return
    raise ValueError(f"no experiment of kind {kind!r} is registered")


def _modules() -> list[str]:
    """The registering modules: the entry points' (by name), ``DOPT_EXPERIMENTS``' and, with
    no entry points installed, ``BUILT_IN``."""
    from importlib.metadata import entry_points

    found = [ep.value.split(":")[0] for ep in
             sorted(entry_points(group=ENTRY_POINTS), key=lambda e: e.name)]
    if not found:
        found = list(BUILT_IN)
    found += [m.strip() for m in os.environ.get(ENV, "").split(",") if m.strip()]
    return list(dict.fromkeys(found))


def load() -> None:
    """Import the registering modules (once; an import error names its module)."""
    if _loaded:
        return
    _loaded.append(True)
    for name in _modules():
        try:
            importlib.import_module(name)
        except ImportError as e:
            raise ImportError(f"experiment module {name!r} ({ENTRY_POINTS} / {ENV}) does not "
                              f"import: {e}") from e


def registered() -> list[Experiment]:
    """Every registered experiment, in registration order (the registering modules loaded
    first)."""
    load()
    return list(_EXPERIMENTS)


def experiment_of(result: Result) -> Experiment | None:
    """The registered experiment that owns ``result`` (None: no one does)."""
    return next((e for e in registered() if e.owns(result)), None)


def bench_kind(bench: str) -> str | None:
    """The kind of a benchmark file whose "bench" field is ``bench`` (None: no experiment
    reads it)."""
    return next((e.kind for e in registered() if bench in e.benches), None)


def register_page(page: Any) -> Any:
    """Register a paper's page (``dopt.lab.report.pages.Page``; ValueError on a paper
    registered already); returns it."""
    if page.paper in _PAGES:
        raise ValueError(f"a page of paper {page.paper!r} is registered already")
    _PAGES[page.paper] = page
    return page


def pages() -> dict[str, Any]:
    """{paper: its page}, in registration order (the registering modules loaded first)."""
    load()
    return dict(_PAGES)
