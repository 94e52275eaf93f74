"""RESULTS.md's sections on the MPC clocks: the virtual clock against the real one, the model
clock's fit, and the speed of the machines behind the virtual clock's MPC sweeps.

Under the virtual clock (the authors' preset) an optimisation lasts its CPU time over a nominal
thread count, so a sweep's lags, and through them its costs, depend on how fast the machine ran
it: machines differ, and a shared one drifts. The baseline (full iLQR, every DoF) does about the
same work per optimisation on a scene whatever the sweep, so its mean optimisation time on a
scene measures the machine there. Sweeps whose baseline trials have the same settings form a
group; the one with the most baseline scenes is the group's reference, and each other sweep
gets, per scene both ran, the ratio of its baseline's mean optimisation time to the
reference's (2: twice as slow).
"""
from __future__ import annotations

import json
import statistics
from pathlib import Path

from dopt.lab.report.base import ReportError, Result, num, pm, section, table
from dopt.lab.trialpack import PackError, stored_trials
from planners.svr_mpc.experiments.report_svr import protocol_line

#: a scene whose ratio reaches this ran on a machine this much slower than the reference's
SLOW = 1.5


def virtual_clock_baselines(folder: Path) -> dict[str, dict[int, tuple[float, str]]]:
    """The baseline trials under the virtual clock in ``folder``/trials: per settings (the
    trial's params less the seed and unset fields, as JSON) and seed, the mean optimisation
    time (ms) and the trial's result as JSON (a trial copied from another sweep has the same
    result: it is not a second measurement)."""
    groups: dict[str, dict[int, tuple[float, str]]] = {}
    try:
        for trial in stored_trials(folder / "trials"):
            text = trial.read_text()
            if '"baseline"' not in text:               # most trials: not worth parsing
                continue
            rec = json.loads(text)
            params = rec.get("params") or {}
            if params.get("method") != "baseline" or params.get("clock") != "virtual":
                continue
            ms = (rec.get("result") or {}).get("opt_ms_mean")
            if ms is None:
                continue
            key = json.dumps({k: v for k, v in params.items() if k != "seed" and v is not None},
                             sort_keys=True)
            groups.setdefault(key, {})[int(params["seed"])] = (
                float(ms), json.dumps(rec["result"], sort_keys=True))
    except (PackError, OSError, ValueError, AttributeError, KeyError, TypeError) as e:
        raise ReportError(f"{folder}: its trials cannot be read: {e}") from e
    return groups


def speed_ratios(sweep: dict[int, tuple[float, str]],
                 reference: dict[int, tuple[float, str]]) -> dict[int, float]:
    """Per seed both ran, each its own trial (not a copy: the results differ), the sweep's
    baseline mean optimisation time over the reference's."""
    return {seed: sweep[seed][0] / reference[seed][0] for seed in sorted(sweep)
            if seed in reference and reference[seed][0] > 0
            and sweep[seed][1] != reference[seed][1]}


def _seeds(seeds: list[int]) -> str:
    """Seeds as ranges: 3, 5-8, 11."""
    runs: list[list[int]] = []
    for s in seeds:
        if runs and s == runs[-1][-1] + 1:
            runs[-1].append(s)
        else:
            runs.append([s])
    return ", ".join(f"{r[0]}-{r[-1]}" if len(r) > 1 else f"{r[0]}" for r in runs)


def host_speed_section(results_dir: Path) -> list[str]:
    """The section: per group of sweeps (the same baseline settings, at least two sweeps) its
    reference and, per other sweep, the scenes beside it, the median ratio and its 10-90 %
    range over those scenes, and the scenes at ``SLOW`` or more."""
    groups: dict[str, list[tuple[str, dict[int, tuple[float, str]]]]] = {}
    for folder in sorted(Path(results_dir).glob("runs/*")):
        if folder.is_dir() and not folder.name.startswith("fig7-"):
            for key, per_seed in virtual_clock_baselines(folder).items():
                groups.setdefault(key, []).append((folder.name, per_seed))
    rows = []
    for key, sweeps in groups.items():
        ref_name, ref = max(sweeps, key=lambda s: (len(s[1]), s[0]))
        others = [(name, per_seed, speed_ratios(per_seed, ref)) for name, per_seed in
                  sorted(sweeps) if name != ref_name]
        others = [o for o in others if o[2]]         # not only copies of the reference's
        if not others:
            continue
        settings = json.loads(key)
        rows.append([f"`{ref_name}` (reference)", f"{settings.get('task')}, "
                     f"{settings.get('problem', 'ours')}", str(len(ref)), "-",
                     f"{num(statistics.median(ms for ms, _ in ref.values()), 0)} ms per "
                     "optimisation", "-", "-"])
        for name, per_seed, ratios in others:
            values = list(ratios.values())
            if len(values) >= 2:
                deciles = statistics.quantiles(values, n=10, method="inclusive")
                spread = f"{num(deciles[0], 2)}-{num(deciles[-1], 2)}"
            else:
                spread = "-"
            slow = [s for s, r in ratios.items() if r >= SLOW]
            rows.append([f"`{name}`", "", str(len(per_seed)), str(len(ratios)),
                         num(statistics.median(values), 2), spread,
                         f"{len(slow)}" + (f" (seeds {_seeds(slow)})" if slow else "")])
    if not rows:
        return []
    return ["## Machine speed behind the virtual clock", "",
            "Under the virtual clock an optimisation lasts its CPU time, so a sweep's lags and "
            "costs depend on the speed of the machine that ran it (machines differ; a shared "
            "one drifts). The baseline does about the same work per optimisation on a scene in "
            "every sweep of the same settings, so its mean optimisation time per scene measures "
            "the machine: per sweep, its ratio to the reference sweep's (the one with the most "
            "baseline scenes) on the scenes both ran, each its own trial; 2 is twice as slow, "
            f"and a scene at {SLOW:g} or more is listed. A seed's rows run one after another, "
            "so within a scene the rows mostly share a speed.", "",
            *table(["sweep", "task, problem", "baseline scenes",
                    "own scenes beside the reference", "median ratio", "10-90 % of scenes",
                    f"scenes at {SLOW:g}x or slower"], rows)]


def clock_check_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        rows = []
        for name, row in d["rows"].items():
            real, virt = row.get("real", {}), row.get("virtual", {})
            rows.append([name, str(real.get("n_trials")), num(real.get("lag_steps_mean"), 1),
                         num(virt.get("lag_steps_mean"), 1), num(row.get("lag_ratio")),
                         num(row.get("opt_ms_ratio")), num(row.get("real_speedup")),
                         pm(num(real.get("mpc_cost_mean"), 0), num(real.get("mpc_cost_ci90"), 0)),
                         pm(num(virt.get("mpc_cost_mean"), 0), num(virt.get("mpc_cost_ci90"), 0)),
                         "yes" if row.get("lag_within_10_percent") else "no",
                         "yes" if row.get("cost_intervals_overlap") else "no"])
        seeds = d.get("seeds")
        return [f"### {d.get('task')}: `{r.name}`", "", protocol_line(d)
                + (f" Seeds {seeds[0]} to {seeds[-1]}." if seeds else ""), "",
                *table(["row", "trials", "lag real", "lag virtual", "lag ratio",
                        "opt. time ratio", "real speed-up", "cost real", "cost virtual",
                        "lag within 10 %", "costs overlap"], rows)]

    return section("The virtual clock against the real clock",
                   "The same trials under both clocks: real (alone, in real time, on the "
                   "machine's threads) and virtual (one thread, CPU time / nominal threads). "
                   "Ratios are virtual / real; the lag should be within 10 % and the MPC cost "
                   "intervals (90 %) should overlap. The real speed-up is one thread's CPU time "
                   "(nominal threads x the virtual optimisation time) over the real one: the "
                   "nominal thread count at which the two clocks agree.", results, page, body)


def clock_check_headline(r: Result) -> str:
    rows = r.data["rows"]
    overlap = sum(bool(v.get("cost_intervals_overlap")) for v in rows.values())
    nominal = r.data.get("nominal_threads")
    seeds = r.data.get("seeds")
    return (f"{r.data.get('task')}" + (f", {nominal:g} nominal threads" if nominal else "")
            + ": lag virtual / real "
            + ", ".join(f"{name} {num(v.get('lag_ratio'))}" for name, v in rows.items())
            + f"; MPC cost intervals overlap on {overlap} of {len(rows)} rows "
              f"({max((v.get('real') or {}).get('n_trials') or 0 for v in rows.values())} "
              f"seeds each" + (f", {seeds[0]}-{seeds[-1]}" if seeds else "") + ")")


def clock_model_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        return table(["task", "points (|C|: ms)", "a (ms)", "b (ms per DoF)", "R^2"],
                     [[task, ", ".join(f"{row['n_dofs']}: {row['ms']:.0f}"
                                       for row in d["rows"] if row["task"] == task),
                       num(f["a_ms"], 1), num(f["b_ms"], 2), num(f["r2"], 3)]
                      for task, f in d["fits"].items()])

    return section("The model clock: CPU time of an MPC optimisation against |C|",
                   "One optimisation of `rand` at theta random DoFs (|C| = 7 + theta) per point, "
                   "the paper's protocol, one simulation thread; ms = CPU time / nominal "
                   "threads. `planners.svr_mpc.CLOCK_MODEL_MS` holds the fits.",
                   results, page, body)
