"""The model clock fitted to the state-vector-reduction authors' own optimisation times.

A comparison of MPC planners whose lag is measured on the host drifts with the host (a loaded
machine makes every row slower and reorders rows whose costs differ by a few per cent). The
``authors`` clock (``SVRMPCSettings.timing.clock``) gives every optimisation the duration the
authors' machine took for one of its size, from their per-episode files (``PaperData/MPC_push_*``,
``../shared/external/ilqr_svr/paper_data``), so a trial gives the same cost on any machine (with
``dopt.blas``'s kernels) and its lag is the authors' lag.

The model, per task: ``ms = a + b |C| + s [SVD ranking]``. Each of the task's runs (every
``iLQR_SVR`` run, Table 1 rows and Fig. 4 points alike, and the two plain ``iLQR`` runs:
baseline at the task's full DoF count, naive at the paper's count, ``PLAIN_DOFS``) gives one
point: the authors' Table 1 statistic (``dopt.lab.stats.authors_mean_ci``) of its DoF and time
columns. The coefficients minimise the squared relative error over the points (every run
weighs alike, whatever its time). The SVD offset is what their files show besides |C|: at equal
|C| the clutter SVD runs take about 30 ms longer (the decomposition); a fit without it misses
clutter's SVD rows by up to 11 %.

``fit_authors_clock(task_dir) -> ClockFit``; ``AUTHORS_CLOCK`` holds the fits, rounded, with
their source, and a test refits them from the files.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dopt.lab.stats import authors_mean_ci
from planners.svr_mpc.authors_data import authors_rows, read_episodes, read_settings

#: the DoF counts the authors' plain iLQR runs logged as 0: baseline covers every DoF of the
#: task, naive the paper's hand-picked set (Table 1's DoF column)
PLAIN_DOFS = {"clutter": {"baseline": 55, "naive": 23},
              "soft": {"baseline": 115, "naive": 79},
              "soft_rigid": {"baseline": 154, "naive": 9}}

#: the fits (``fit_authors_clock`` on ``paper_data/<TASK_DIRS[task]>``, rounded to 0.01 ms):
#: (a, b, s) of ms = a + b |C| + s [SVD]; source: DMackRus/iLQR_SVR ``PaperData`` (runs of
#: 2024-06-10/12), 38 clutter runs, 9 per soft task; tests/planners/svr_mpc/test_authors_clock.py
#: refits them
AUTHORS_CLOCK = {"clutter": (40.29, 8.16, 29.82), "soft": (12.41, 5.0, -11.65),
                 "soft_rigid": (396.38, 24.68, -14.94)}


@dataclass(frozen=True)
class ClockFit:
    """A task's fit: ``a`` (ms), ``b`` (ms per DoF), ``svd`` (ms added by the SVD ranking);
    ``points``: {run folder (plain runs: baseline, naive): (DoFs, ms, svd)} it was fitted to."""

    a: float
    b: float
    svd: float
    points: dict

    def ms(self, n_dofs, svd=False) -> np.ndarray:
        """The fitted duration (ms) of optimisations over ``n_dofs`` DoFs (any shape)."""
        return self.a + self.b * np.asarray(n_dofs, float) + self.svd * np.asarray(svd, float)


def model_ms(task: str, method: str) -> tuple[float, float]:
    """The ``dopt.mpc.MPCConfig.model_ms`` (a, b) of a trial of ``method`` (a name of
    ``planners.svr.METHODS``) on ``task`` under the authors' clock: the SVD offset folded into
    a."""
    if task not in AUTHORS_CLOCK:
        raise ValueError(f"no authors' clock for task {task!r}; fitted: {tuple(AUTHORS_CLOCK)}")
    a, b, s = AUTHORS_CLOCK[task]
    return (a + (s if method == "svr-svd" else 0.0), b)


def run_points(task: str, task_dir: Path) -> dict[str, tuple[float, float, bool]]:
    """{run: (DoFs, ms, svd)}: the authors' statistic of each run's DoF and time columns."""
    task_dir = Path(task_dir)
    out = {}
    for name, r in authors_rows(task_dir).items():
        if name in PLAIN_DOFS[task]:
            out[name] = (float(PLAIN_DOFS[task][name]),
                         authors_mean_ci(r["episodes"]["time"])[0], False)
    for folder in sorted((task_dir / "iLQR_SVR").iterdir()):
        if (folder / "summary.csv").is_file():
            e = read_episodes(folder / "summary.csv")
            svd = read_settings(folder / "summary.yaml")["Eigen vector method"].lower() == "true"
            out[folder.name] = (authors_mean_ci(e["dofs"])[0], authors_mean_ci(e["time"])[0],
                                svd)
    return out


def fit_authors_clock(task: str, task_dir: Path) -> ClockFit:
    """Fit ``ms = a + b |C| + s [SVD]`` to the runs of one of the authors' task folders (e.g.
    ``paper_data/MPC_push_mcl``), minimising the squared relative error (module docstring).
    ValueError: an unknown task, or too few runs (fewer than 3, or no SVD run)."""
    if task not in PLAIN_DOFS:
        raise ValueError(f"unknown task {task!r}; choose from {tuple(PLAIN_DOFS)}")
    points = run_points(task, task_dir)
    P = np.array(list(points.values()), float)
    if len(P) < 3 or not P[:, 2].any():
        raise ValueError(f"{task_dir}: {len(P)} runs ({int(P[:, 2].sum()) if len(P) else 0} "
                         f"SVD): a fit of 3 coefficients needs at least 3, one SVD")
    X = np.stack([np.ones(len(P)), P[:, 0], P[:, 2]], axis=1)
    w = 1.0 / P[:, 1]
    (a, b, s), *_ = np.linalg.lstsq(X * w[:, None], P[:, 1] * w, rcond=None)
    return ClockFit(float(a), float(b), float(s), points)
