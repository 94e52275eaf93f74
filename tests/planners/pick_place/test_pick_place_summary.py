"""planners.pick_place: what a Fig. 7 summary records beside the costs: the settings a run
changed from its protocol (``PickPlaceSettings.departures``) and the CEM iteration after which
each trial's best cost last fell (``last_improvement``)."""

from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

from planners.pick_place import PROTOCOLS, PickPlaceSettings, last_improvement, summarize


@pytest.mark.parametrize("protocol", tuple(PROTOCOLS))
@pytest.mark.parametrize("task, goal", [("rope", "fold"), ("cloth", "diagonal"),
                                        ("cloth", "underneath")])
def test_a_preset_departs_from_nothing_and_a_changed_field_is_named(protocol, task, goal):
    s = PickPlaceSettings.preset(task, goal, protocol=protocol)
    assert s.departures(protocol) == {}
    assert replace(s, threads=7).departures(protocol) == {}     # not a setting of the run
    changed = replace(s, n=s.n + 1, cem=replace(s.cem, population=s.cem.population + 5))
    assert changed.departures(protocol) == {"n": s.n + 1,
                                            "cem.population": s.cem.population + 5}
    # against the other protocol the differences are exactly the fields the presets differ in
    other = next(p for p in PROTOCOLS if p != protocol)
    theirs = PickPlaceSettings.preset(task, goal, protocol=other)
    assert set(s.departures(other)) == set(theirs.departures(protocol))


def test_quick_settings_are_judged_against_the_quick_preset():
    s = PickPlaceSettings.preset("cloth", "side", quick=True)
    assert s.departures("ours", quick=True) == {}
    assert "n" in s.departures("ours") and "cem.iterations" in s.departures("ours")


def _trial(history, stages, scripted=False):
    return {"method": "scripted" if scripted else "simple", "seed": 0,
            "cost_history": history, "stage_of_iteration": stages,
            "s_per_iteration": None if scripted else 1.0}


@pytest.mark.parametrize("history, stages, want", [
    ([5.0, 4.0, 4.0, 3.0, 3.0], [0] * 5, 4),        # fell last at iteration 4 of 5
    ([5.0, 5.0, 5.0], [0] * 3, 1),                  # never fell: the first sample stood
    ([5.0, 4.0, 3.0], [0] * 3, 3),                  # still falling at the end
    ([9.0, 1.0, 8.0, 7.0, 7.0], [0, 0, 1, 1, 1], 2),  # within the last stage only
])
def test_last_improvement_counts_within_the_last_stage(history, stages, want):
    assert last_improvement(_trial(history, stages)) == want


def test_last_improvement_agrees_with_a_direct_count_on_random_histories():
    rng = np.random.default_rng(3)
    for _ in range(200):
        n = int(rng.integers(1, 40))
        steps = rng.random(n) < 0.3
        history = list(np.minimum.accumulate(10.0 - np.cumsum(steps * rng.random(n))))
        falls = [i + 1 for i in range(1, n) if history[i] < history[i - 1]]
        assert last_improvement(_trial(history, [0] * n)) == (falls[-1] if falls else 1)


def records(results: list[dict]) -> list[dict]:
    """Results as the sweep stores them: {"params", "result"} (the params its trial ran)."""
    return [{"params": {"method": r["method"], "seed": r["seed"]}, "result": r}
            for r in results]


def test_summary_lists_each_seeds_last_improvement_and_none_for_the_scripted_policy():
    def result(method, seed, history, scripted=False):
        return {**_trial(history, [0] * len(history), scripted), "method": method,
                "seed": seed, "final_cost": history[-1], "n_candidates": [4],
                "n_rollouts": 10, "n_unstable_rollouts": 0, "unstable": False}
    out = summarize(records([result("simple", 1, [3.0, 2.0, 2.0]),
                             result("simple", 0, [3.0, 3.0]),
                             result("scripted", 0, [2.5], scripted=True)]),
                    ["simple", "scripted"], ["final_cost"])
    assert out["simple"]["seeds"] == [0, 1]
    assert out["simple"]["last_improvements"] == [1, 2]
    assert out["scripted"]["last_improvements"] == [None]


def test_summary_holds_each_methods_difference_to_simple_with_welchs_interval():
    def result(method, seed, cost, unstable=False):
        return {**_trial([cost], [0]), "method": method, "seed": seed, "final_cost": cost,
                "n_candidates": [4], "n_rollouts": 10, "n_unstable_rollouts": 0,
                "unstable": unstable}
    simple, original = [0.010, 0.014, 0.012], [0.030, 0.020, 0.040, 0.026]
    rs = ([result("simple", i, c) for i, c in enumerate(simple)]
          + [result("original", i, c) for i, c in enumerate(original)]
          + [result("original", 9, 5.0, unstable=True)]       # not in means or differences
          + [result("scripted", 0, 0.015)])
    out = summarize(records(rs), ["simple", "original", "scripted"], ["final_cost"])
    o = out["original"]
    # Welch by hand: variances of the means and the Welch-Satterthwaite degrees of freedom
    va, vb = np.var(simple, ddof=1) / 3, np.var(original, ddof=1) / 4
    dof = (va + vb) ** 2 / (va ** 2 / 2 + vb ** 2 / 3)
    assert o["final_cost_minus_simple_mean"] == pytest.approx(np.mean(original) - np.mean(simple))
    assert o["final_cost_minus_simple_ci95"] == pytest.approx(
        stats.t.ppf(0.975, dof) * np.sqrt(va + vb))
    assert out["scripted"]["final_cost_minus_simple_ci95"] is None      # one value: no spread
    assert "final_cost_minus_simple_mean" not in out["simple"]
    # without Simple there is nothing to differ from
    assert "final_cost_minus_simple_mean" not in summarize(records(rs), ["original"],
                                                           ["final_cost"])["original"]
