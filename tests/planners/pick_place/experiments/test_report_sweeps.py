"""Which committed trials a recorded Fig. 7 summary holds (``report_sweeps``): its methods'
seeds run with its settings, so a sweep of other settings sharing the folder (the prepared
start of a multi-layer fold beside the chained one recorded) is listed as in progress, not
counted as the summary's."""

import json
from pathlib import Path

from hypothesis import given
from hypothesis import strategies as st

from dopt.lab.report.base import Result
from planners.pick_place.experiments.report_sweeps import fig7_trials, ran_settings

#: settings values as JSON holds them
VALUES = st.one_of(st.none(), st.booleans(), st.integers(-5, 5), st.sampled_from(["a", "b"]))
SETTINGS = st.dictionaries(st.sampled_from(["n", "goal", "physics", "fold_start", "bound"]),
                           VALUES, max_size=5)


@given(SETTINGS, st.integers(0, 4), st.integers(0, 4))
def test_settings_agree_with_themselves_whatever_the_thread_count(s, a, b):
    assert ran_settings({"settings": {**s, "threads": a}}, {**s, "threads": b})


@given(SETTINGS, st.sampled_from(["n", "goal", "physics", "fold_start", "bound"]))
def test_a_changed_or_added_setting_disagrees_and_none_is_absent(s, key):
    summary = {"settings": s}
    changed = {**s, key: "changed"}
    assert not ran_settings(summary, changed)
    # a setting the summary predates, left at None by the trial, is the same run
    absent = {k: v for k, v in s.items() if k != key}
    assert ran_settings({"settings": absent}, {**absent, key: None})


def test_per_size_summaries_and_unreadable_settings_are_left_to_the_size_match():
    assert ran_settings({"per_size": {}, "settings": {"20": {"n": 20}}}, {"n": 30})
    assert ran_settings({"settings": {"n": 20}}, None)
    assert ran_settings({}, {"n": 20})


def _write(folder: Path, method: str, seed: int, tag: str, settings: dict) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    key = f"{method}-seed{seed}-{tag}"
    (folder / f"{key}.json").write_text(json.dumps(
        {"key": key, "params": {"settings": settings, "method": method, "seed": seed},
         "result": {"method": method, "seed": seed, "final_cost": 0.01}}))


def test_a_summary_holds_its_seeds_of_its_own_settings_only(tmp_path):
    chained = {"task": "cloth", "goal": "reflective", "n": 20, "threads": 1}
    prepared = {**chained, "fold_start": "prepared", "threads": 0}
    trials = tmp_path / "trials"
    for seed in (0, 1):
        _write(trials, "simple", seed, "1d8ae933", chained)
    _write(trials, "simple", 0, "a65f6d6e", prepared)
    _write(trials, "original", 0, "1d8ae933", chained)           # a method it lacks
    summary = Result(tmp_path / "fig7-cloth-reflective.json",
                     {"experiment": "fig7", "settings": {**chained, "threads": 0},
                      "methods": {"simple": {"seeds": [0, 1]}}})
    held = sorted(p.stem for p in fig7_trials(tmp_path, summary))
    assert held == ["simple-seed0-1d8ae933", "simple-seed1-1d8ae933"]
    # recorded from the prepared start instead, it holds only that trial
    summary.data["settings"] = prepared
    assert [p.stem for p in fig7_trials(tmp_path, summary)] == ["simple-seed0-a65f6d6e"]
