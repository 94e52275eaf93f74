"""python -m planners.bench cloth-budget --quick: the same CEM samples of both folds simulated
with the fixed move and with sized moves, its JSON fields and their arithmetic, and fewer
steps with sized moves. Speed targets stay out of tests: nothing here judges a time."""
import contextlib
import io
import json

import pytest

from planners.bench.__main__ import main
from planners.bench.budget import FOLDS, QUICK

FOLD_FIELDS = ("steps_ratio", "cpu_ratio", "wall_ratio", "cost_delta_median_mm",
               "cost_delta_p90_mm", "cost_abs_delta_p90_mm", "fig7_panel_h", "samples",
               "steps_old", "steps_new", "cpu_old_s", "cpu_new_s", "wall_old_s", "wall_new_s")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """The quick bench once through its command line: (the printed JSON, the result file)."""
    out = tmp_path_factory.mktemp("cloth-budget") / "cloth-budget.json"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(["cloth-budget", "--quick", "--record", str(out)]) == 0
    return json.loads(printed.getvalue()), json.loads(out.read_text())


def test_every_fold_has_its_ratios_cost_differences_and_panel(run):
    out, _ = run
    assert out["bench"] == "cloth-budget" and out["quick"] and out["n"] == QUICK["n"]
    assert tuple(out["folds"]) == FOLDS
    for fold, row in out["folds"].items():
        assert set(FOLD_FIELDS) <= set(row), fold
        assert row["samples"] == QUICK["iterations"] * QUICK["population"]
        assert row["steps_ratio"] == pytest.approx(row["steps_new"] / row["steps_old"])
        assert row["cpu_ratio"] == pytest.approx(row["cpu_new_s"] / row["cpu_old_s"])
        assert row["wall_ratio"] == pytest.approx(row["wall_new_s"] / row["wall_old_s"])
        assert row["paired"] + max(row["nonfinite_old"], row["nonfinite_new"]) <= \
            row["samples"]
        if row["paired"]:
            assert row["cost_abs_delta_p90_mm"] >= 0
        control = row["control"]                 # the fixed move one step longer
        assert {"cost_delta_median_mm", "cost_abs_delta_p90_mm", "paired"} <= set(control)
        panel = row["fig7_panel_h"]
        assert panel["trials"] == 40 and panel["sequences"] > 0
        assert panel["new"] / panel["old"] == pytest.approx(row["cpu_ratio"])


def test_sized_moves_simulate_fewer_steps(run):
    out, _ = run
    assert all(row["steps_ratio"] < 1 for row in out["folds"].values())
    assert out["steps_ratio"] < 1
    assert out["steps_ratio"] == pytest.approx(
        sum(r["steps_new"] for r in out["folds"].values())
        / sum(r["steps_old"] for r in out["folds"].values()))


def test_the_record_holds_a_row_per_fold_with_its_provenance(run):
    out, record = run
    assert record["experiment"] == "cloth_budget"
    assert {"command", "git_commit", "versions"} <= set(record["provenance"])
    assert [r["fold"] for r in record["rows"]] == list(FOLDS)
    assert record["steps_ratio"] == out["steps_ratio"]


def test_the_control_moves_one_step_longer():
    from dataclasses import replace

    from dopt.tasks.pick.scene import PickPlaceTask
    from planners.bench.budget import fold_settings, one_step_longer
    from planners.pick_place import make_problem

    s = fold_settings("diagonal", QUICK["n"], 1, QUICK["population"])
    problem = make_problem(s, 0)
    task = PickPlaceTask(problem.scene, problem.stages[0].goal)
    slower = replace(s, picker_speed=one_step_longer(task)).picker()
    assert slower.steps(task.picker.dt)[2] == task.picker.move_steps + 1
