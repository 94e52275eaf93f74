"""The state-vector-reduction paper's experiments, registered with the report
(``dopt.lab.experiment``): one ``Experiment`` per kind of result file (Table 1, Fig. 4, the
clock check, the SVR explanation, the clock and iLQR benchmarks, the authors' data), and the
paper's page. Loaded by the entry-point group ``dopt.experiments`` (pyproject.toml).
"""

from __future__ import annotations

from dopt.lab.experiment import Experiment, register_experiment, register_page
from dopt.lab.report.base import source
from planners.svr_mpc.experiments import report_catalogue as cat
from planners.svr_mpc.experiments import report_claims, report_map
from planners.svr_mpc.experiments.report_bench import ilqr_bench_section, paper_svr_section
from planners.svr_mpc.experiments.report_clock import (
    clock_check_headline,
    clock_check_section,
    clock_model_section,
    host_speed_section,
)
from planners.svr_mpc.experiments.report_pages import PAGE
from planners.svr_mpc.experiments.report_stale import svr_stale
from planners.svr_mpc.experiments.report_svr import (
    SVR,
    _table1_columns,
    fig4_headline,
    fig4_section,
    fig4_vs_paper_section,
    ordering_sentence,
    orderings,
    paper_preset_table1,
    paper_table1,
    svr_explain_section,
    table1_headline,
    table1_section,
    table1_vs_paper_section,
)
from planners.svr_mpc.experiments.report_sweeps import mpc_sweeps_in_progress_section


def _claims(*titles: str) -> list:
    return [c for c in report_claims.CLAIMS if c.title in titles]


def _rows(*items: str) -> list:
    return [r for r in report_map.ROWS if r.item.startswith(items)]


def _entries(kind: str) -> list:
    return [e for e in cat.CATALOGUE if e.kind == kind]


class OnProtocol(Experiment):
    """A kind run on Table 1's protocol: stale against today's preset and code
    (``report_stale.svr_stale``)."""

    paper = SVR

    def stale(self, result, results_dir, trials):
        return svr_stale(result, results_dir, trials)

    def catalogue(self):
        return _entries(self.kind)


class Table1(OnProtocol):
    """Table 1: iLQR-SVR in asynchronous MPC (``experiments/mpc.py``)."""

    kind, rank, script = "table1", 6, "python experiments/mpc.py"
    trial_fields = ("methods", "paired", "authors_statistic", "versus", "feedback_effect",
                    "derivatives_effect", "row_settings", "lag_cost_tau", "choice",
                    "versus_unstable_kept", "trial_commits")

    def section(self, results, page):
        return table1_section(results, page)

    def headline(self, result):
        return table1_headline(result)

    def headline_notes(self, results, page):
        _, published = paper_table1(results)
        beside = [(t, r) for t in published if (r := paper_preset_table1(results, t))]
        if not beside:
            return []
        return ["Table 1 under `--preset authors` (else `paper`) against the paper's printed "
                "Table 1 (MPC cost / baseline, means; the rows side by side are in "
                "\"State-vector reduction, Table 1 beside the paper\" below):", "",
                *(f"- {task}: paper cheapest first {', '.join(o['paper_order'][:3])}; ours "
                  f"{', '.join(o['our_order'][:3])}. {ordering_sentence(o)}; "
                  f"{source(r, page)}." for task, r in beside
                  for o in [orderings(*_table1_columns(published[task], r.data))])]

    def beside(self, results, page):
        return table1_vs_paper_section(results, page)

    def in_progress(self, results_dir, results):
        return mpc_sweeps_in_progress_section(results_dir, results)

    def map_rows(self):
        return _rows("Table 1 ")

    def claims(self):
        return _claims("SVR costs less than the baseline", "SVR costs less than a random choice",
                       "SVR optimises faster", "The gain is the lag saved")

    def rebuild(self, data, records, info):
        return cat.table1_rebuild(data, records, info)


class ClockCheck(OnProtocol):
    """Table 1's virtual clock against the real clock (``experiments/clock_check.py``)."""

    kind, rank, script = "clock_check", 12, "python experiments/clock_check.py"
    trial_fields = ("rows", "trial_commits")

    def section(self, results, page):
        return clock_check_section(results, page)

    def headline(self, result):
        return clock_check_headline(result)

    def trial_files(self, folder, result):
        return cat.clock_check_trials(folder, result)

    def rebuild(self, data, records, info):
        return cat.clock_check_rebuild(data, records, info)


class Fig4(OnProtocol):
    """Fig. 4: the importance threshold rho and random DoFs theta
    (``experiments/rho_sweep.py``)."""

    kind, rank, script = "fig4", 7, "python experiments/rho_sweep.py"
    trial_fields = ("points", "versus", "cost_dofs_r", "trial_commits")

    def section(self, results, page):
        return fig4_section(results, page)

    def headline(self, result):
        return fig4_headline(result)

    def beside(self, results, page):
        return fig4_vs_paper_section(results, page)

    def map_rows(self):
        return _rows("Fig. 4 ")

    def claims(self):
        return _claims("A larger rho keeps fewer DoFs", "Never re-adding DoFs does worse",
                       "The best rho is moderate")

    def rebuild(self, data, records, info):
        return cat.fig4_rebuild(data, records, info)


class SvrExplain(OnProtocol):
    """Which DoFs each method holds, and what rho cuts (``experiments/svr_explain.py``)."""

    kind, rank, script = "svr_explain", 10, "python experiments/svr_explain.py"
    trial_fields = ("rows", "trial_commits")

    def section(self, results, page):
        return svr_explain_section(results, page)

    def map_rows(self):
        return _rows("The authors' clutter")

    def rebuild(self, data, records, info):
        return cat.svr_explain_rebuild(data, records, info)


class Section(Experiment):
    """A kind that only has its RESULTS.md section."""

    paper = SVR

    def __init__(self, kind: str, rank: float, render, script: str):
        self.kind, self.rank, self._render, self.script = kind, rank, render, script

    def section(self, results, page):
        return self._render(results, page)


class ClockModel(Section):
    """The MPC clocks' model (``python -m planners.bench clock``), and the machine speed
    behind the virtual clock's sweeps."""

    def __init__(self):
        super().__init__("clock_model", 9, clock_model_section, "python -m planners.bench clock")

    def in_progress(self, results_dir, results):
        return host_speed_section(results_dir)


def _register() -> None:
    for x in (Table1(), ClockCheck(), Fig4(), SvrExplain(), ClockModel(),
              Section("ilqr_bench", 11, ilqr_bench_section, "python -m planners.bench ilqr"),
              Section("paper_svr", 13, paper_svr_section,
                      "python experiments/paper_reference.py")):
        register_experiment(x)
    register_page(PAGE)


_register()
