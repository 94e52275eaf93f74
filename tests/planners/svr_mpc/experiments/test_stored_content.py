"""The SVR experiments' stored trials judged by content (``runner.SCHEMA``): a non-finite MPC
cost and a record of another seed stored under a trial's name are moved aside and recomputed
(the first once failed every rerun: the summary's non-finite ValueError)."""
import json
import math

import pytest

from dopt.lab import jsonio
from dopt.lab.provenance import COMMIT_ENV
from planners.svr_mpc.experiments import mapping, runner, table1


@pytest.fixture(autouse=True)
def fixed_code(monkeypatch):
    monkeypatch.setenv(COMMIT_ENV, "c0ffee")


# ---------------------------------------------------------------------------------- MPC
def _fake_episode(params, report=None, keep_controls=False):
    return {**dict.fromkeys(runner.SCHEMA.result, 0.5), "unstable": False, "seed": params["seed"]}


def test_a_non_finite_mpc_cost_is_moved_aside_and_recomputed(tmp_path):
    """A stored mpc_cost of +inf (null with its reason) reached the summary: every rerun
    died there (authors_kept: 1 non-finite value(s))."""
    args = table1.parse_args(["--quick", "--rules", "baseline", "--out", str(tmp_path)])
    (trial,) = mapping.make_trials(args)
    jsonio.write_atomic(tmp_path / "trials" / f"{trial.key}.json", {
        "key": trial.key, "params": trial.params, "code": {"version": "0", "commit": "c0ffee"},
        "result": {**dict.fromkeys(runner.SCHEMA.result, 0.5), "mpc_cost": math.inf}})
    records, res = runner.run(args, [trial], fn=_fake_episode)
    assert res.ran == [trial.key] and records[0]["result"]["mpc_cost"] == 0.5
    assert "'mpc_cost' is inf" in res.recomputed[trial.key]


def test_an_mpc_record_of_another_seed_under_a_trials_name_is_recomputed(tmp_path):
    args = table1.parse_args(["--quick", "--rules", "baseline", "--out", str(tmp_path),
                              "--trials", "2"])
    first, second = mapping.make_trials(args)
    (tmp_path / "trials").mkdir()
    (tmp_path / "trials" / f"{first.key}.json").write_text(json.dumps({
        "key": first.key, "params": second.params,
        "code": {"version": "0", "commit": "c0ffee"}, "result": _fake_episode(second.params)}))
    records, res = runner.run(args, [first], fn=_fake_episode)
    assert res.ran == [first.key] and records[0]["result"]["seed"] == first.params["seed"]
    assert "another trial's" in res.recomputed[first.key]
