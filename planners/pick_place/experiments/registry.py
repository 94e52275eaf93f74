"""The key-particle paper's experiments, registered with the report (``dopt.lab.experiment``):
one ``Experiment`` per kind of result file (Fig. 4's key particles, Fig. 7, the scaling study,
the drag encoding's sweep, the Panda, the cloth benchmarks), and the paper's page. Loaded by
the entry-point group ``dopt.experiments`` (pyproject.toml).
"""

from __future__ import annotations

from dopt.lab.experiment import Experiment, register_experiment, register_page
from dopt.lab.report.engine import Entry
from dopt.lab.report.resummarize import commits_of
from planners.pick_place.experiments import report_claims, report_kp, report_map
from planners.pick_place.experiments.report_budget import cloth_budget_section
from planners.pick_place.experiments.report_encoding import (
    TRIAL_FIELDS,
    encoding_headline,
    encoding_rebuild,
    encoding_section,
    encoding_stale,
    encoding_trial_files,
)
from planners.pick_place.experiments.report_fig7 import (
    HOLM_NOTE,
    _departs,
    fig7_claims_lines,
    fig7_departures,
    fig7_headline,
    fig7_section,
)
from planners.pick_place.experiments.report_pages import PAGE
from planners.pick_place.experiments.report_paper import FIG7_PANELS, KP
from planners.pick_place.experiments.report_physics import physics_reference_section
from planners.pick_place.experiments.report_stale import pick_stale
from planners.pick_place.experiments.report_sweeps import (
    fig7_trials,
    scaling_trials,
    sweeps_in_progress_section,
)


def _claims(*titles: str) -> list:
    return [c for c in report_claims.CLAIMS if c.title in titles]


def _rows(*items: str) -> list:
    return [r for r in report_map.ROWS if r.item.startswith(items)]


#: the command line of each task's Fig. 7 panels (experiments/<name>.py; another task: its name)
FIG7_SCRIPTS = {"cloth": "cloth_fold", "rope": "rope"}


class Section(Experiment):
    """A kind that only has its RESULTS.md section (a benchmark's, most of them)."""

    def __init__(self, kind: str, rank: float, render, script: str, benches=(), paper=KP):
        self.kind, self.rank, self._render, self.script = kind, rank, render, script
        self.benches, self.paper = tuple(benches), paper

    def section(self, results, page):
        return self._render(results, page)


class KeyParticles(Section):
    """Fig. 4, Sec. IV-C.1: the key particles of each goal."""

    def __init__(self):
        super().__init__("key_particles", 1, report_kp.kp_section,
                         "python experiments/key_particles.py --task all")

    def headline(self, result):
        return report_kp.kp_headline(result)

    def catalogue(self):
        return [Entry(KP, "Fig. 4, Sec. IV-C.1: key particles of each goal", self.script,
                      self.kind)]

    def map_rows(self):
        return _rows("Fig. 4, Sec. IV-C.1")

    def claims(self):
        return _claims("Few key particles per goal")

    def stale(self, result, results_dir, trials):
        return pick_stale(result, results_dir)


class KeyParticlesAuthors(Section):
    """Sec. IV-C.1 on the authors' own cloth goals (``python -m deformables.bench authors``)."""

    def __init__(self):
        super().__init__("kp_authors", 4, report_kp.kp_authors_section,
                         "python -m deformables.bench authors", ("key-particles-authors",))

    def map_rows(self):
        return _rows("Sec. IV-C.1 on the authors'")

    def claims(self):
        return _claims("The same keys on the authors' goals")


class Fig7(Experiment):
    """Fig. 7: the final cost of pick-and-place, per panel and method."""

    kind, paper, rank = "fig7", KP, 5
    script = "python experiments/cloth_fold.py / rope.py"
    trial_fields = ("methods", "trials_wall_s", "trial_commits")

    def section(self, results, page):
        return fig7_section(results, page)

    def headline(self, result):
        return fig7_headline(result)

    def catalogue(self):
        return [Entry(KP, f"Fig. 7 {panel}",
                      f"python experiments/{FIG7_SCRIPTS.get(task, task)}.py --goal {goal}",
                      self.kind, {"task": task, "goal": goal})
                for (task, goal), panel in FIG7_PANELS.items()]

    def departure(self, result):
        return fig7_departures(result)

    def headline_intro(self, results):
        departing = "; ".join(sorted({fig7_departures(r) for r in results if _departs(r)}))
        return (f" Fig. 7 runs that change a protocol's settings ({departing}) are in the "
                f"Fig. 7 section, each beside its protocol's file." if departing else "")

    def headline_notes(self, results, page):
        claims = fig7_claims_lines(results, page)
        return ["Fig. 7's claims on the recorded files (each panel on the paper's metric, "
                "named; 95 % intervals separate or overlapping; difference: the other "
                f"method's mean minus Simple's ± its Welch 95 % interval; {HOLM_NOTE}):",
                "", *claims] if claims else []

    def in_progress(self, results_dir, results):
        return sweeps_in_progress_section(results_dir, results)

    def map_rows(self):
        return _rows("Fig. 7 (")

    def claims(self):
        return _claims("Rope: Simple beats Original, Random is worst",
                       "Cloth: Simple beats Original on every fold",
                       "Cloth: the gap grows with difficulty", "Cloth: Random beats Original")

    def trial_files(self, folder, result):
        return fig7_trials(folder, result)

    def stale(self, result, results_dir, trials):
        return pick_stale(result, results_dir)

    def rebuild(self, data, records, info):
        from planners.pick_place import metric_names, summarize

        # the library's own metric names (the goal's registration), without building a scene
        names = metric_names(data.get("task"), data.get("goal"))
        return {"methods": summarize(records, list(data.get("methods") or {}), names),
                "trials_wall_s": float(sum(r["result"]["wall_s"] for r in records)),
                "trial_commits": commits_of(records)}


class Scaling(Section):
    """Sec. V: the gain against the particle count."""

    def __init__(self):
        super().__init__("fig7_scaling", 20, report_kp.scaling_section,
                         "python experiments/fig7_scaling.py --goal diagonal")

    def map_rows(self):
        return _rows("Sec. V:")

    def claims(self):
        return _claims("The gain grows with the particle count")

    def trial_files(self, folder, result):
        return scaling_trials(folder, result)


class Encoding(Section):
    """Sec. V under the authors' drag encoding: the gain against N candidate points on one
    physics mesh (``experiments/fig7_encoding.py``). Its catalogue entries, README row and
    claim stay hidden until a file is recorded."""

    trial_fields = TRIAL_FIELDS
    goals = ("diagonal", "side")

    def __init__(self):
        super().__init__("fig7_encoding", 20.5, encoding_section,
                         "python experiments/fig7_encoding.py --goal diagonal")

    def headline(self, result):
        return encoding_headline(result)

    def catalogue(self):
        return [Entry(KP, f"Sec. V under the authors' drag encoding, {goal} fold",
                      f"python experiments/fig7_encoding.py --goal {goal}", self.kind,
                      {"goal": goal}, hidden_until_recorded=True) for goal in self.goals]

    def map_rows(self):
        return _rows("Sec. V under the authors' drag encoding")

    def claims(self):
        return _claims("The gain grows with the candidate count under the authors' encoding")

    def trial_files(self, folder, result):
        return encoding_trial_files(folder, result)

    def stale(self, result, results_dir, trials):
        return encoding_stale(result)

    def rebuild(self, data, records, info):
        return encoding_rebuild(data, records)


class PandaExecute(Section):
    """Sec. IV-D: a Panda executes the plans (simulated)."""

    trial_fields = ("goals", "trial_commits")

    def __init__(self):
        super().__init__("panda_execute", 14, report_kp.panda_section,
                         "python experiments/panda_execute.py --trials 3 --out "
                         "docs/results/runs/panda --record docs/results/panda-execute.json")

    def headline(self, result):
        return report_kp.panda_headline(result)

    def catalogue(self):
        return [Entry(KP, "Sec. IV-D: a Panda executes the diagonal and side plans",
                      self.script, self.kind)]

    def map_rows(self):
        return _rows("Sec. IV-D:")

    def claims(self):
        return _claims("A robot arm executes the plans")

    def stale(self, result, results_dir, trials):
        return pick_stale(result, results_dir)

    def rebuild(self, data, records, info):
        from planners.pick_place.experiments.panda_execute import summarize

        return {"goals": summarize(records), "trial_commits": commits_of(records)}


def _register() -> None:
    for x in (KeyParticles(), KeyParticlesAuthors(), Fig7(), Scaling(), Encoding(),
              PandaExecute(),
              Section("kp_compare", 2, report_kp.kp_compare_section,
                      "python -m deformables.bench compare", ("key-particles-compare",)),
              Section("kp_paper_scale", 3, report_kp.kp_paper_scale_section,
                      "python -m deformables.bench paper-scale",
                      ("key-particles-paper-scale",)),
              Section("physics", 8, report_kp.physics_section, "python -m planners.bench",
                      ("cloth", "rope")),
              Section("cloth_steps", 15, report_kp.cloth_steps_section,
                      "python -m planners.bench cloth-steps"),
              Section("cem_limit", 16, report_kp.cem_limit_section,
                      "python -m planners.bench cem-limit"),
              Section("settle_rest", 17, report_kp.settle_rest_section,
                      "python -m planners.bench settle"),
              Section("cloth_warp", 18, report_kp.cloth_warp_section,
                      "python -m planners.bench cloth-warp"),
              Section("random_reach", 19, report_kp.random_reach_section,
                      "python experiments/random_reach.py"),
              Section("physics_reference", 21, physics_reference_section,
                      "python -m planners.bench physics-reference"),
              Section("cloth_budget", 22, cloth_budget_section,
                      "python -m planners.bench cloth-budget")):
        register_experiment(x)
    register_page(PAGE)


_register()

__all__ = ["Encoding", "Fig7", "KeyParticles", "KeyParticlesAuthors", "PandaExecute", "Scaling",
           "Section"]
