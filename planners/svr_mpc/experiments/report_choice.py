"""The Table 1 section's lines on what each row's C held (``planners.svr_mpc.choice``): how
often it held the goal object, how long the authors' executor held the arm, and which of those
orders the rows' costs.
"""

from __future__ import annotations

from dopt.lab.report.base import num, table
from dopt.lab.report.stats import pval

#: the fields ``choice_fields`` ranks against the rows' cost, with their words
FIELDS = {"goal_held_share": "share of optimisations whose C held the goal object",
          "held_steps_mean": "steps the arm stood still", "lag_steps_mean": "lag",
          "landing_offset_mean": "landing row's distance from the lag"}


def choice_lines(choice: dict | None) -> list[str]:
    """A table per row (goal held, held steps, lag, median cost ratio) and the Kendall taus
    against the cost; nothing for a summary without "choice"."""
    if not choice or not choice.get("rows"):
        return []
    taus = [f"{words} {num(t['tau'])} (p {pval(t['p'])})"
            for field, words in FIELDS.items() if (t := choice["tau"].get(field))]
    return ["", "What each row's C held, from the stored active sets (optimisations after the "
            "first; the goal object's planar DoFs), beside the steps the executor held the arm "
            "and the lag:", "",
            *table(["row", "C held the goal", "held steps (mean)", "lag (steps)",
                    "landing row - lag (mean abs.)", "cost / baseline (median per seed)",
                    "trials"],
                   [[row, num(v["goal_held_share"]), num(v["held_steps_mean"], 0),
                     num(v["lag_steps_mean"], 1), num(v.get("landing_offset_mean"), 1),
                     num(v["cost_ratio_median"]), str(v["n_trials"])]
                    for row, v in choice["rows"].items()]),
            *(["", "Kendall tau against the rows' cost (baseline aside): " + "; ".join(taus)
               + "."] if taus else [])]
