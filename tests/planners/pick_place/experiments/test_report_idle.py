"""Plans that pick nothing (``report_idle``): which trials they are, the sentence that counts
them per method, and, on the committed prepared-start trials, that such a plan ends where the
settled start lies whatever the seed."""

import json
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from dopt.lab.trialpack import stored_trials
from planners.cem import NONE
from planners.pick_place.experiments.report_idle import (
    BEAT_MARGIN,
    idle_plans_line,
    picks_nothing,
    trial_records,
)
from planners.pick_place.scaling import fold_costs

RUNS = Path(__file__).resolve().parents[4] / "docs" / "results" / "runs"

steps = st.lists(st.integers(min_value=-1, max_value=399), min_size=1, max_size=4)


@given(st.lists(steps, min_size=1, max_size=3))
def test_a_plan_picks_nothing_exactly_when_no_step_names_a_particle(plan):
    result = {"actions": [{"stage": "s", "particles": p} for p in plan]}
    assert picks_nothing(result) == (max(max(p) for p in plan) < 0)


@pytest.mark.parametrize("result", [
    {}, {"actions": []}, {"actions": [{"particles": []}]}, {"actions": "none"},
    {"actions": [{"stage": "s"}]}, {"actions": [{"particles": ["x"]}]}, None, [NONE]])
def test_a_result_without_a_readable_plan_is_not_counted_as_idle(result):
    assert picks_nothing(result) is False


def _trial(cost, *particles):
    return {"final_cost": cost, "actions": [{"particles": list(particles)}]}


def test_the_sentence_counts_idle_and_beating_trials_per_method_in_the_figures_order():
    start = 0.02216
    records = [("random", _trial(start, NONE, NONE)),
               ("simple", _trial(start, NONE, NONE)),
               ("simple", _trial(start - 2 * BEAT_MARGIN, 3, NONE)),   # beats it
               ("simple", _trial(start - 0.8 * BEAT_MARGIN, 5, 7)),    # shown equal: not
               ("original", _trial(start + 0.001, 12, 40)),
               ("scripted", _trial(start - 0.0004, 0, 19))]
    text = idle_plans_line(records)
    assert "to 22.2 mm from this goal" in text
    assert ("CEM(Simple) 1 of 3, CEM(Original) 0 of 1, CEM(Random) 1 of 1, Scripted 0 of 1."
            in text)
    assert "closer than that: CEM(Simple) 1, CEM(Original) 0, CEM(Random) 0, Scripted 1." in text


def test_idle_trials_that_end_apart_give_the_start_as_a_range():
    text = idle_plans_line([("simple", _trial(0.0171, NONE)), ("random", _trial(0.0185, NONE))])
    assert "to 17.1-18.5 mm" in text


def test_no_idle_plan_gives_no_sentence():
    busy = [("simple", _trial(0.01, 1, 2)), ("original", {"final_cost": 0.02})]
    assert idle_plans_line(busy) == ""
    assert idle_plans_line([]) == ""


@pytest.mark.parametrize("goal", ["reflective", "underneath"])
def test_committed_idle_plans_end_where_the_prepared_start_settles_whatever_the_seed(goal):
    """The start settles deterministically, so every trial whose plan picks nothing ends at the
    same cost, and the prepared previous fold lies closer to the goal than the flat sheet."""
    folder = RUNS / f"fig7-cloth-{goal}" / "trials"
    if not folder.is_dir():
        pytest.skip(f"no committed trials under {folder}")
    records = []
    for f in stored_trials(folder):
        d = json.loads(f.read_text())
        if d["params"]["settings"].get("fold_start") == "prepared":
            records.append((d["params"]["method"], d["result"]))
    idle = [r["final_cost"] for _, r in records if picks_nothing(r)]
    if not idle:
        pytest.skip(f"no committed prepared-start {goal} trial picks nothing")
    flat, _ = fold_costs(goal, 20, 0.3)
    assert max(idle) - min(idle) < 1e-9
    assert 0 < idle[0] < flat
    assert len(trial_records(stored_trials(folder))) >= len(records)
