"""The cloth-budget bench's record on RESULTS.md: each fold's ratios and paired cost changes
in its row, through the registered experiment (not a kind branch)."""

import json

from dopt.lab.report.engine import generate


def fold(name: str, steps_ratio: float) -> dict:
    return {"fold": name, "n": 20, "samples": 300, "paired": 297, "iterations": 3,
            "population": 100, "threads_old": 1, "threads_new": 2, "steps_ratio": steps_ratio,
            "cpu_ratio": 0.61, "wall_ratio": 0.33, "move_mean_m": 0.27,
            "cost_delta_median_mm": 0.4, "cost_delta_p90_mm": 7.5,
            "cost_abs_delta_p90_mm": 9.31, "control": {"cost_abs_delta_p90_mm": 8.75},
            "fig7_panel_h": {"old": 22.0, "new": 13.5}}


def test_each_fold_is_a_row_of_its_section(tmp_path):
    record = {"experiment": "cloth_budget", "bench": "cloth-budget", "protocol": "paper",
              "iterations": 3, "seed": 0, "cores": 2, "quick": False,
              "rows": [fold("diagonal", 0.58), fold("side", 0.66)],
              "provenance": {"command": "python -m planners.bench cloth-budget --record x",
                             "git_commit": "abc", "date": "2026-12-05"}}
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "cloth-budget.json").write_text(json.dumps(record))
    page = tmp_path / "RESULTS.md"
    text = generate(tmp_path / "results", page, tmp_path / "README.md")["files"][page]
    section = text[text.index("## Key particles: the cloth rollouts' budget"):]
    rows = [line for line in section.splitlines() if line.startswith(("| diagonal", "| side"))]
    assert rows[0].split(" | ")[1:5] == ["20 x 20", "297 / 300", "0.58", "0.61"]
    assert rows[1].split(" | ")[3] == "0.66"
    assert rows[0].split(" | ")[9:11] == ["9.3", "8.8"]     # |change| p90, its control
    assert rows[0].rstrip(" |").endswith("22.0 -> 13.5")
    assert "Other result files" not in text              # the kind is registered
