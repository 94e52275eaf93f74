"""An MPC trial's name (``planners.svr_mpc.trial_names``): the one identity over the flat
params against the defaults of ``SVRMPCSettings``, and the committed trials of a sweep found
under their older names by a rerun (``Schema.aliases``)."""

import json
from pathlib import Path

import pytest

from dopt.lab.sweep import is_finished
from dopt.lab.trialpack import stored_trials
from planners.svr_mpc import SVRMPCSettings, trial_params
from planners.svr_mpc.experiments.runner import SCHEMA
from planners.svr_mpc.trial_names import legacy_trial_key, reference, trial_key

RUNS = Path(__file__).resolve().parents[3] / "docs" / "results" / "runs"


def test_the_name_is_task_row_seed_and_the_hash_of_what_departs_from_the_defaults():
    s = SVRMPCSettings(task="soft").with_params(method="svr-svd", theta=4, rho=500.0)
    p = trial_params(s, 3)
    key = trial_key(p)
    assert key.startswith("soft-svd-t4-r500-seed3-") and len(key.rsplit("-", 1)[1]) == 8
    assert trial_key({**p, "threads": 8}) == key                  # run-only
    assert trial_key({**p, "rho": 500}) == key                    # 500 and 500.0: one value
    assert trial_key({**p, "seed": 4}) != key
    assert trial_key(trial_params(s.with_params(feedback=True), 3)) != key
    assert trial_key(trial_params(s, 3, "svr")) == key            # the default optimiser
    # a setting the params lack (a trial written before it existed) is at its default
    assert trial_key({k: v for k, v in p.items() if k != "push_tail"}) == key
    assert set(reference("soft")) == set(p) - {"seed", "threads"}
    with pytest.raises(TypeError, match="params must be a dict"):
        trial_key([p])


def test_a_reuse_any_rerun_finds_the_committed_authors_executor_trials():
    """What ``--reuse-any`` on docs/results/runs/fig4-clutter-authors-executor sees: each
    committed trial, stored under its legacy key, is finished under its new name."""
    folder = RUNS / "fig4-clutter-authors-executor"
    trials = stored_trials(folder / "trials")
    if not trials:
        pytest.skip(f"no committed trials under {folder}")
    for t in trials:
        record = json.loads(t.read_text())
        p = record["params"]
        assert record["key"] == legacy_trial_key(p) != trial_key(p)
        assert is_finished(folder, trial_key(p), reuse="any", schema=SCHEMA, params=p)


def test_a_setting_the_legacy_name_cannot_spell_has_no_alias_and_is_checked():
    """A setting added after the legacy names (here a made-up one) away from its default: the
    trial has no legacy name to be found under, and the identity check compares it, so an old
    trial of the same legacy name never stands for it; at its default nothing changes."""
    from planners.svr_mpc.trial_names import trial_aliases, trial_identity

    p = trial_params(SVRMPCSettings(task="clutter").with_params(slowdown=1.0), 2)
    later = {**p, "future_setting": 3}
    assert trial_aliases(p) == (legacy_trial_key(p),)
    assert trial_aliases(later) == ()
    assert legacy_trial_key(later) == legacy_trial_key(p)
    assert trial_identity(later) != trial_identity(p)
    assert SCHEMA.params_problem(p, later) is not None
    assert SCHEMA.params_problem(p, p) is None
