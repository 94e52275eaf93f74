"""The state-vector-reduction authors' per-episode data read into their Table 1, and their
statistic applied to our trials.

The authors' ``PaperData`` (DMackRus/iLQR_SVR) holds, per task, ``iLQR/<run>/`` and
``iLQR_SVR/<run>/`` folders with a ``summary.csv`` (one row per MPC episode: final cost, average
DoFs, average optimisation time, ...) and a ``summary.yaml`` (the run's settings). Their Table 1
cell of a column is ``dopt.lab.stats.authors_mean_ci`` of it (an outlier fence, then the mean and a
normal 90 % half-width), costs divided by the baseline row's kept mean.

- ``authors_rows(task_dir)``: the run folders of one task by our Table 1 row names
  (``planners.svr_mpc.TABLE1_ROWS``): baseline is the slower of the two ``iLQR`` folders (all
  DoFs), naive the other; rand the ``iLQR_SVR`` Sum run with theta 5 and a threshold rho of at
  least ``RAND_MIN_RHO`` (1e6 on clutter, 1e15 on the soft tasks: no DoF survives it but the
  theta re-added at random); the SVD and Sum rows by their theta and rho.
- ``authors_table1(task_dir)``: the statistic on those rows.
- ``authors_statistic(records)``: the same statistic on our trials (``{"params", "result"}``,
  as ``planners.svr_mpc.summarize`` takes), to report beside our paired statistics.

Shapes: n episodes of a run, k <= n kept by the authors' fence.
"""

from __future__ import annotations

import csv
import logging
from pathlib import Path

import numpy as np

from dopt.lab.stats import authors_kept, authors_mean_ci
from planners.svr_mpc.settings import TABLE1_ROWS, row_label, row_name

log = logging.getLogger(__name__)

#: our task name -> the authors' task folder under their ``PaperData``
TASK_DIRS = {"clutter": "MPC_push_mcl", "soft": "MPC_push_soft",
             "soft_rigid": "MPC_push_soft_rigid"}
#: our measure -> the authors' ``summary.csv`` column
COLUMNS = {"cost": "Final cost", "time": "Average optimisation time (ms)",
           "dofs": "Average dofs"}
#: the smallest K threshold rho of a Rand run (the authors' 1e6 on clutter, 1e15 on soft)
RAND_MIN_RHO = 1e6
#: the theta of the Rand row (``TABLE1_ROWS["rand-t5"]``)
RAND_THETA = 5


def read_settings(path: Path) -> dict[str, str]:
    """A run's ``summary.yaml``: flat ``key: value`` lines -> {key: value as text}.

    Raises
    ------
    ValueError
        A non-empty line is not ``key: value``.
    """
    out = {}
    for n, line in enumerate(Path(path).read_text().splitlines(), 1):
        if not line.strip():
            continue
        key, sep, value = line.partition(":")
        if not sep or not key.strip():
            raise ValueError(f"{path}:{n}: not a 'key: value' line: {line!r}")
        out[key.strip()] = value.strip()
    return out


def read_episodes(path: Path) -> dict[str, np.ndarray]:
    """A run's ``summary.csv``: {our measure (``COLUMNS``): values, shape (n,)}.

    Raises
    ------
    ValueError
        The file has no episodes, lacks a column of ``COLUMNS`` or holds a non-number.
    """
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{path}: no episodes")
    missing = [c for c in COLUMNS.values() if c not in rows[0]]
    if missing:
        raise ValueError(f"{path}: no column(s) {missing}")
    try:
        return {m: np.array([float(r[c]) for r in rows]) for m, c in COLUMNS.items()}
    except (TypeError, ValueError) as e:
        raise ValueError(f"{path}: not a number in a column of {list(COLUMNS.values())}: {e}") \
            from None


def _svr_row(settings: dict[str, str], where: Path) -> str | None:
    """Our Table 1 row of an ``iLQR_SVR`` run's settings, or None (a Fig. 4 sweep point)."""
    try:
        theta = int(settings["num_dofs_readd"])
        rho = float(settings["K_matrix_threshold"])
        svd = settings["Eigen vector method"].lower()
    except KeyError as e:
        raise ValueError(f"{where}: no setting {e.args[0]!r}") from None
    if svd not in ("true", "false"):
        raise ValueError(f"{where}: 'Eigen vector method' is {svd!r}, not true or false")
    if svd == "false" and theta == RAND_THETA and rho >= RAND_MIN_RHO:
        return row_name("rand", theta, rho)
    name = row_name("svr-svd" if svd == "true" else "svr-sum", theta, rho)
    return name if name in TABLE1_ROWS else None


def authors_rows(task_dir: Path) -> dict[str, dict]:
    """The run folders of one of the authors' tasks (e.g. ``.../paper_data/MPC_push_mcl``) by
    our Table 1 row names, in ``TABLE1_ROWS`` order.

    Returns
    -------
    dict
        {row: {"run_dir": the folder's name, "settings": its summary.yaml,
        "episodes": {"cost", "time", "dofs"}: arrays of shape (n,)}}; rows without a run are
        absent.

    Raises
    ------
    ValueError
        ``task_dir`` lacks ``iLQR/`` or ``iLQR_SVR/``, ``iLQR/`` does not hold exactly two runs
        (baseline and naive), or two runs claim one row.
    """
    task_dir = Path(task_dir)
    for sub in ("iLQR", "iLQR_SVR"):
        if not (task_dir / sub).is_dir():
            raise ValueError(f"{task_dir}: no {sub}/ folder of runs")

    def run(folder: Path) -> dict:
        return {"run_dir": folder.name, "settings": read_settings(folder / "summary.yaml"),
                "episodes": read_episodes(folder / "summary.csv")}

    plain_dirs = [d for d in sorted((task_dir / "iLQR").iterdir()) if d.is_dir()]
    if len(plain_dirs) != 2:
        raise ValueError(f"{task_dir / 'iLQR'}: {len(plain_dirs)} runs, expected 2 "
                         "(baseline, naive)")
    plain = [run(d) for d in plain_dirs]
    plain.sort(key=lambda r: -float(r["episodes"]["time"].mean()))
    rows = {"baseline": plain[0], "naive": plain[1]}
    for folder in sorted((task_dir / "iLQR_SVR").iterdir()):
        if not folder.is_dir():
            continue
        r = run(folder)
        name = _svr_row(r["settings"], folder)
        if name is None:
            log.debug("%s: not a Table 1 row (a Fig. 4 point)", folder)
        elif name in rows:
            raise ValueError(f"{task_dir}: runs {rows[name]['run_dir']} and {folder.name} "
                             f"are both {name}")
        else:
            rows[name] = r
    return {k: rows[k] for k in TABLE1_ROWS if k in rows}


def _cells(episodes: dict[str, np.ndarray], base_cost: float | None,
           dofs_logged: bool = True) -> dict:
    """The statistic's cells of one row: {"cost_mean", "cost_ci" (over ``base_cost``; None
    without one), "cost_kept_mean", "time_mean", "time_ci", "dofs_mean", "dofs_ci" (None when
    not ``dofs_logged``), "n_kept_<measure>", "n_episodes"}."""
    out: dict = {}
    for measure, values in episodes.items():
        if measure == "dofs" and not dofs_logged:
            out.update(dofs_mean=None, dofs_ci=None, n_kept_dofs=None)
            continue
        mean, ci = authors_mean_ci(values)
        out[f"n_kept_{measure}"] = int(authors_kept(values).size)
        if measure == "cost":
            out["cost_kept_mean"] = mean
            if base_cost is None:
                mean = ci = None
            else:
                mean, ci = mean / base_cost, ci / base_cost
        out[f"{measure}_mean"], out[f"{measure}_ci"] = mean, ci
    out["n_episodes"] = int(len(episodes["cost"]))
    return out


def authors_table1(task_dir: Path) -> dict[str, dict]:
    """The authors' Table 1 statistic on one task's run folders (``authors_rows``).

    Returns
    -------
    dict
        {row: {"cost_mean", "cost_ci" (final cost over baseline's kept mean), "cost_kept_mean"
        (final cost, not normalised), "time_mean", "time_ci" (ms), "dofs_mean", "dofs_ci",
        "n_kept_cost", "n_kept_time", "n_kept_dofs", "n_episodes", "run_dir"}}; the DoF cells
        of baseline and naive are None (the authors' plain iLQR logs 0 DoFs; their table
        prints the preset counts).

    Raises
    ------
    ValueError
        As ``authors_rows``, or the task has no baseline run.
    """
    rows = authors_rows(task_dir)
    if "baseline" not in rows:
        raise ValueError(f"{task_dir}: no baseline run")
    base = authors_mean_ci(rows["baseline"]["episodes"]["cost"])[0]
    return {name: {**_cells(r["episodes"], base, dofs_logged=name not in ("baseline", "naive")),
                   "run_dir": r["run_dir"]}
            for name, r in rows.items()}


def authors_statistic(records: list[dict], baseline: str = "baseline") -> dict[str, dict]:
    """The authors' Table 1 statistic on our trials of one task.

    Parameters
    ----------
    records : list of dict
        Finished trials, {"params", "result"} as ``planners.svr_mpc.summarize`` takes: the row
        is ``row_label(params)``; cost ``result["mpc_cost"]``, time ``result["opt_ms_mean"]``,
        DoFs ``result["dofs_mean"]``.
    baseline : str
        The row whose kept mean cost normalises the costs.

    Returns
    -------
    dict
        {row: {"cost_mean", "cost_ci" (None without a ``baseline`` row), "cost_kept_mean",
        "time_mean", "time_ci", "dofs_mean", "dofs_ci", "n_kept_cost", "n_kept_time",
        "n_kept_dofs", "n_episodes"}}, rows in order of first appearance.

    Raises
    ------
    ValueError
        A record lacks "params" or a result field, or a row's values are not finite.
    """
    by: dict[str, dict[str, list]] = {}
    for i, r in enumerate(records):
        try:
            row, res = row_label(r["params"]), r["result"]
            values = {"cost": res["mpc_cost"], "time": res["opt_ms_mean"],
                      "dofs": res["dofs_mean"]}
        except (KeyError, TypeError) as e:
            raise ValueError(f"record {i}: not a finished trial ({e!r} missing)") from None
        cols = by.setdefault(row, {m: [] for m in values})
        for m, v in values.items():
            cols[m].append(float(v))
    episodes = {row: {m: np.asarray(v) for m, v in cols.items()} for row, cols in by.items()}
    base = (authors_mean_ci(episodes[baseline]["cost"])[0] if baseline in episodes else None)
    return {row: _cells(e, base) for row, e in episodes.items()}


def authors_travel(task_dir: Path, layouts: Path | None = None) -> dict[str, dict]:
    """How far the authors' goal object came toward its goal, per Table 1 row of one of their
    tasks (``authors_rows``): their ``Final dist`` per episode and, on clutter with
    ``layouts``, the travel: episode i ran scene i of ``layouts`` (``push_mcl_layouts/{i}.csv``,
    ``dopt.tasks.push.authors.read_layout``), whose start distance is the goal cylinder's xy
    to its target; travel = start distance - final distance.

    Returns {row: {"travel_median" (m; None without ``layouts``), "final_distance_median" (m),
    "n_episodes"}}; a ValueError names a run without a ``Final dist`` value in every episode
    or a missing scene file.
    """
    from dopt.tasks.push.authors import read_layout

    out = {}
    for row, r in authors_rows(task_dir).items():
        path = Path(task_dir) / ("iLQR" if row in ("baseline", "naive") else "iLQR_SVR") \
            / r["run_dir"] / "summary.csv"
        with open(path, newline="") as f:
            final = [float(e["Final dist"]) for e in csv.DictReader(f) if e.get("Final dist")]
        if len(final) != len(r["episodes"]["cost"]):
            raise ValueError(f"{path}: no 'Final dist' value in every episode")
        travel = None
        if layouts is not None:
            start = []
            for i in range(len(final)):
                scene = Path(layouts) / f"{i}.csv"
                if not scene.is_file():
                    raise ValueError(f"{layouts}: no scene {i}.csv for episode {i} of {path}")
                lay = read_layout(scene)
                start.append(float(np.hypot(*(lay.goal - lay.poses[0, :2]))))
            travel = float(np.median(np.asarray(start) - np.asarray(final)))
        out[row] = {"travel_median": travel, "final_distance_median": float(np.median(final)),
                    "n_episodes": len(final)}
    return out
