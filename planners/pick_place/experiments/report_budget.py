"""The cloth rollouts' budget on RESULTS.md (issue 90): ``python -m planners.bench
cloth-budget``'s record (``planners.bench.budget``), the same CEM samples simulated with the
fixed move on one thread and with moves sized per sample on every core, paired."""

from __future__ import annotations

from pathlib import Path

from dopt.lab.report.base import Result, num, section, table


def _fold_row(f: dict) -> list:
    panel, control = f.get("fig7_panel_h") or {}, f.get("control") or {}
    return [f["fold"], f"{f['n']} x {f['n']}", f"{f['paired']} / {f['samples']}",
            num(f["steps_ratio"]), num(f["cpu_ratio"]),
            f"{num(f['wall_ratio'])} ({f['threads_new']} threads)", num(f["move_mean_m"]),
            num(f["cost_delta_median_mm"], 1), num(f["cost_delta_p90_mm"], 1),
            num(f["cost_abs_delta_p90_mm"], 1), num(control.get("cost_abs_delta_p90_mm"), 1),
            f"{num(panel.get('old'), 1)} -> {num(panel.get('new'), 1)}"]


def cloth_budget_section(results: list[Result], page: Path) -> list[str]:
    def body(r: Result) -> list[str]:
        d = r.data
        return [f"### `{r.name}`: protocol {d.get('protocol')}, {d.get('iterations')} CEM "
                f"iterations per fold, seed {d.get('seed')}, {d.get('cores')} cores"
                + (" (quick)" if d.get("quick") else ""), "",
                *table(["fold", "cloth", "samples paired", "steps new / old",
                        "CPU new / old", "wall new / old", "mean move (m)",
                        "cost change p50 (mm)", "p90", "|change| p90", "control |change| p90",
                        "Fig. 7 panel (h) old -> new"],
                       [_fold_row(f) for f in d["rows"]])]

    return section("Key particles: the cloth rollouts' budget, fixed against sized moves",
                   "`python -m planners.bench cloth-budget`: the samples of a CEM(Simple) plan "
                   "of the paper protocol's fold (its first iterations: the widest "
                   "distribution) simulated with the fixed move on one thread, then again "
                   "with each sample's move sized to its displacement on every core; the "
                   "steps, CPU and wall time new over old in the same run, the per-sample "
                   "change of Eq. 2 (new minus old, the samples stable both ways), the same "
                   "for the fixed move one step longer (the control: the smallest change of "
                   "the schedule, the floor below which no retiming brings a sample's cost), "
                   "and the projected wall hours of one Fig. 7 panel (4 methods x 10 seeds) "
                   "on the recording machine's cores.", results, page, body)
