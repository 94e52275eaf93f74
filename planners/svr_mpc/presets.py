"""The SVR MPC protocols ("ours", "paper", "authors") and the paper's Table 1 rows, in one
table that gives every number its source.

Sources: the paper (the text in ``../shared/seeds/state_vector_reduction_mpc.txt``: Sec. 5.1
the tasks, Table 1 the rows), the authors' code and data (``iLQR_SVR``, its ``PaperData``;
file and function as ``../shared/notes/svr-authors-setup.md`` section 1 records them) or ours
(chosen or measured; docs/DESIGN-NOTES.md). ``SVRMPCSettings.paper``, ``.authors`` and
``.preset`` (``planners.svr_mpc.settings``) read them: a protocol is the settings' defaults
("ours") with its ``Setting`` rows on top, "authors" on top of "paper". A row names its
setting flat, as a trial's params do (``cost``, ``clock``; ``settings.RECORD_PATHS`` says
which group holds it: ``timing.clock``), so a protocol reads as the trials record it. A
task's T, dt, Y and slowdown are the paper's Sec. 5.1 numbers and live in its
``dopt.tasks.PUSH_TASKS`` spec.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

#: the nine rows of the paper's Table 1 by name: (method, theta, rho). Source: the paper,
#: Table 1 (its row headings: iLQR-Baseline, iLQR-Rand theta = 5, iLQR-Naive, iLQR-SVR-SVD
#: and iLQR-SVR-Sum at theta 10 / rho 1, theta 10 / rho 500, theta 5 / rho 1)
TABLE1_ROWS = {
    "baseline": ("baseline", 0, 1.0),
    "rand-t5": ("rand", 5, 1.0),
    "naive": ("naive", 0, 1.0),
    "svd-t10-r1": ("svr-svd", 10, 1.0),
    "svd-t10-r500": ("svr-svd", 10, 500.0),
    "svd-t5-r1": ("svr-svd", 5, 1.0),
    "sum-t10-r1": ("svr-sum", 10, 1.0),
    "sum-t10-r500": ("svr-sum", 10, 500.0),
    "sum-t5-r1": ("svr-sum", 5, 1.0),
}

#: the row a protocol runs unless another is named: the paper's first SVR row (Table 1)
DEFAULT_ROW = "sum-t10-r1"


@dataclass(frozen=True)
class Setting:
    """One setting of a protocol: ``value`` (the same on every task) or ``per_task`` (task ->
    value; a task it does not name takes ``value``), and ``source``, where the number comes
    from."""

    value: object
    source: str
    per_task: Mapping | None = None

    def __post_init__(self):
        if not isinstance(self.source, str) or not self.source:
            raise ValueError(f"Setting.source must name where the value comes from, got "
                             f"{self.source!r}")

    def on(self, task: str):
        """The value on ``task``."""
        return (self.per_task or {}).get(task, self.value)


#: The paper's protocol (``SVRMPCSettings.paper``), over the settings' defaults.
PAPER: dict[str, Setting] = {
    "cost": Setting("paper", "the paper's Eq. 2 cost (Sec. 4), no end-effector term; on soft "
                    "the authors' push_soft task file adds a terminal reach residual "
                    "(svr-authors-setup.md, 1: costs, soft HEAD reach 0/1e5): paper-reach",
                    per_task={"soft": "paper-reach"}),
    "warm_start": Setting(True, "the authors' set-up motion and first push "
                          "(PushBaseClass::JacobianEEControl; svr-authors-setup.md, 1: warm "
                          "start), ported in dopt.tasks.push.warm_start"),
    "control_noise": Setting(0.05, "the authors' interactive AsyncMPC adds 5 % control noise "
                             "(svr-authors-setup.md, 1: noise)"),
    "clock": Setting("virtual", "ours: the lag is the optimisation's CPU time over the nominal "
                     "threads, so it does not depend on what else the machine runs (the "
                     "paper's agent ran on the wall clock, Sec. 5.1)"),
}

#: The authors' regime (``SVRMPCSettings.authors``), over the paper's protocol: where the
#: paper's text and their code differ, the code, which generated their data.
AUTHORS: dict[str, Setting] = {
    "problem": Setting("authors", "their scenes, objects and contacts (mujoco_models "
                       "cylinder_pushing_heavyClutter.xml, push_soft.xml, push_soft_rigid.xml; "
                       "svr-authors-setup.md, 1: scene files), dopt.tasks.push.authors"),
    "cost": Setting(None, "their cost weights, no control cost (PaperData/MPC_push_mcl/Cost "
                    "config; soft_rigid and soft: the task yaml files; svr-authors-setup.md, "
                    "1: costs), dopt.tasks.push.costs.AUTHORS_COSTS",
                    per_task={"clutter": "authors-clutter", "soft": "authors-soft",
                              "soft_rigid": "authors-soft_rigid"}),
    "control_noise": Setting(0.0, "every PaperData/*/summary.yaml records controls_noise: 0 "
                             "(GenTestingData.cpp scales the noise by it; svr-authors-setup.md, "
                             "1: noise)"),
    "executor": Setting("authors", "their data generator's executor (main.cpp::MPCUntilComplete:"
                        " hold after 80 controls, land at the nearest nominal state; "
                        "dopt.mpc)"),
    "clock": Setting("authors", "the model clock fitted to their own optimisation times "
                     "(PaperData, planners.svr_mpc.authors_clock)"),
}

#: the protocols by name: "ours" (the ``SVRMPCSettings`` defaults), "paper", "authors"
PROTOCOLS: dict[str, tuple[dict[str, Setting], ...]] = {
    "ours": (),
    "paper": (PAPER,),
    "authors": (PAPER, AUTHORS),
}


def protocol_fields(name: str, task: str) -> dict:
    """The settings protocol ``name`` sets on ``task``, by flat name (its rows in order, a
    later one over an earlier; ``SVRMPCSettings.with_params`` takes them); ValueError naming
    the protocols."""
    if name not in PROTOCOLS:
        raise ValueError(f"unknown preset {name!r}; choose from {tuple(PROTOCOLS)}")
    out: dict = {}
    for table in PROTOCOLS[name]:
        out.update({field: s.on(task) for field, s in table.items()})
    return out


def row_fields(row: str) -> dict:
    """The method, theta and rho of the Table 1 row ``row``; ValueError naming the rows."""
    if row not in TABLE1_ROWS:
        raise ValueError(f"unknown Table 1 row {row!r}; choose from {tuple(TABLE1_ROWS)}")
    method, theta, rho = TABLE1_ROWS[row]
    return {"method": method, "theta": theta, "rho": rho}
