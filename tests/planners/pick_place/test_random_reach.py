"""planners.random_reach: the re-drawn candidates are the ones the recorded trials planned
over, and the blind-draw chance matches an enumeration."""

import itertools
import json
from dataclasses import replace
from fnmatch import fnmatch
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dopt.lab.trialpack import stored_trials
from planners.pick_place.random_reach import p_blind, random_reach, reach_summary, settings_groups

RUNS = Path(__file__).resolve().parents[3] / "docs" / "results" / "runs"


def test_p_blind_matches_enumeration():
    rng = np.random.default_rng(3)
    need = np.where(rng.random(9) < 0.4, 0.05, 0.0)
    for k in (1, 2, 3, 4):
        draws = list(itertools.combinations(range(len(need)), k))
        blind = sum(all(need[i] <= 0.01 for i in d) for d in draws) / len(draws)
        assert p_blind(need, k) == pytest.approx(blind, abs=1e-12)
    with pytest.raises(ValueError, match="cannot draw"):
        p_blind(need, 10)


@pytest.mark.parametrize("fold", ["diagonal", "reflective"])
def test_redrawn_candidates_hold_every_recorded_pick(fold):
    """Every particle a recorded CEM(Random) trial picked is among the candidates re-drawn for
    that stage from its seed and settings (a pick of -1 is a no-op action); the reflective
    folder holds both fold starts, each re-drawn under its own."""
    folder = RUNS / f"fig7-cloth-{fold}" / "trials"
    records = [json.loads(t.read_text()) for t in stored_trials(folder)     # loose or packed
               if fnmatch(t.name, "random-seed[01]-*.json")]
    if not records:
        pytest.skip(f"no committed CEM(Random) trials under {folder}")
    groups = settings_groups(records)
    for group in groups:
        reach = random_reach(group)
        assert [t.seed for t in reach] == sorted(r["params"]["seed"] for r in group)
        by_seed = {r["params"]["seed"]: r for r in group}
        for t in reach:
            stages = {s.stage: set(s.candidates) for s in t.stages}
            for action in by_seed[t.seed]["result"]["actions"]:
                picked = {p for p in action["particles"] if p >= 0}
                assert picked <= stages[action["stage"]], (t.seed, action, stages)
            for s in t.stages:
                assert 0.0 <= s.reach <= 1.0 and s.need <= s.max_need
    if len(groups) > 1:
        with pytest.raises(ValueError, match="more than one setting"):
            random_reach(records)


def test_at_least_matches_binomial_and_enumeration():
    from scipy.stats import binom

    from planners.pick_place.random_reach import at_least

    for k in range(6):
        assert at_least([0.3] * 5, k) == pytest.approx(binom.sf(k - 1, 5, 0.3), abs=1e-12)
    chances = [0.1, 0.5, 0.8]
    for k in range(4):
        total = sum(np.prod([c if hit else 1 - c for c, hit in zip(chances, hits, strict=True)])
                    for hits in itertools.product([0, 1], repeat=3) if sum(hits) >= k)
        assert at_least(chances, k) == pytest.approx(total, abs=1e-12)


def test_reach_summary_counts():
    from planners.pick_place.random_reach import StageReach, TrialReach

    def trial(seed, cost, need):
        st = StageReach("s", [0], need, 0.4, need / 0.4, 0.1)
        return TrialReach(seed, cost, [st], need / 0.4, need <= 0.01)

    s = reach_summary([trial(0, 0.06, 0.0), trial(1, 0.01, 0.3), trial(2, 0.02, 0.2)])
    assert s["blind"] == 1 and s["blind_expected"] == pytest.approx(0.3)
    assert s["p_blind_at_least"] == pytest.approx(1 - 0.9 ** 3)
    assert s["spearman_rho"] == pytest.approx(-1.0)
    assert s["cost_blind"] == pytest.approx(0.06) and s["cost_seeing"] == pytest.approx(0.015)


def test_a_folder_of_two_fold_starts_reports_each_on_its_own(tmp_path):
    """``experiments/random_reach.py``'s folder report splits a folder holding a multi-layer
    fold's chained and prepared-start trials into one report per start, never pairing one
    start's seed with the other's candidates."""
    from planners.pick_place.experiments.random_reach import folder_report

    # seed 0 of both starts: the chained 12 x 12 panel's and the paper panel's (loose or
    # packed, whichever folder holds them once the paper panel records)
    records = [json.loads(t.read_text())
               for run in ("fig7-ours-cloth-reflective", "fig7-cloth-reflective")
               for t in stored_trials(RUNS / run / "trials")
               if fnmatch(t.name, "random-seed0-*.json")]
    starts = {r["params"]["settings"].get("fold_start") for r in records}
    if not {None, "prepared"} <= starts:
        pytest.skip(f"the committed reflective trials hold fold starts {starts}, not both")
    records = [next(r for r in records if r["params"]["settings"].get("fold_start") == start)
               for start in (None, "prepared")]
    (tmp_path / "trials").mkdir()
    for r in records:
        (tmp_path / "trials" / f"{r['key']}.json").write_text(json.dumps(r))
    reports = folder_report(tmp_path, 0.01)
    assert sorted(str(r["fold_start"]) for r in reports) == ["None", "prepared"]
    for rep in reports:
        (trial,) = rep["trials"]
        own = next(r for r in records
                   if r["params"]["settings"].get("fold_start") == rep["fold_start"])
        assert trial["final_cost"] == own["result"]["final_cost"]
        assert rep["mean_final_cost"]["random"] == own["result"]["final_cost"]
        assert ({s["stage"] for s in trial["stages"]}
                == {a["stage"] for a in own["result"]["actions"]})


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["reflective", "underneath"]),
                          st.sampled_from([None, "prepared"]), st.sampled_from([12, 20]),
                          st.sampled_from(["simple", "random"]), st.integers(0, 9),
                          st.integers(1, 4)), max_size=12))
def test_settings_groups_partition_records_by_what_they_ran(draws):
    """Records drawn at random over fold, start, size, method, seed and threads: the groups
    hold every record once, in its order; one group's records ran one setting whatever their
    method, seed and threads; two groups ran two."""
    from planners.pick_place import PickPlaceSettings

    records = []
    for goal, start, n, method, seed, threads in draws:
        s = replace(PickPlaceSettings.preset("cloth", goal, protocol="paper"), n=n,
                    fold_start=start, threads=threads)
        records.append({"params": {"settings": s.to_dict(), "method": method, "seed": seed}})
    groups = settings_groups(records)
    position = {id(r): i for i, r in enumerate(records)}
    assert sorted(position[id(r)] for g in groups for r in g) == list(range(len(records)))
    for g in groups:
        assert [position[id(r)] for r in g] == sorted(position[id(r)] for r in g)
        assert len({(r["params"]["settings"]["goal"], r["params"]["settings"].get("fold_start"),
                     r["params"]["settings"]["n"]) for r in g}) == 1
    assert len(groups) == len({(goal, start, n) for goal, start, n, *_ in draws})
