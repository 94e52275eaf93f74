"""``python -m planners.bench settle`` on a small cloth: a rest speed no sample reaches cuts
nothing and changes no cost; one every sample reaches cuts each action's settle down to the
test's minimum, exactly; the record holds its rows."""

import json

import numpy as np
import pytest

import planners.bench.__main__ as bench
from dopt.tasks.pick.settle import RestTest
from planners.bench.settle import bench_settle


@pytest.fixture(scope="module")
def rows():
    return bench_settle([5], speeds=[1e-12, 1e9], samples=4, threads=1)["rows"]


def test_a_speed_nothing_reaches_is_the_plain_rollout(rows):
    never = rows[0]
    assert never["steps_saved"] == 0.0
    assert never["cost_change_mm"]["max"] == 0.0 and never["same_elites"]


def test_a_speed_everything_reaches_cuts_every_settle_to_the_minimum(rows):
    always = rows[1]
    kept = int(round(RestTest().min_settle / always["dt"]))
    want = (always["settle_steps"] - kept) / always["K"]
    assert always["settle_share"] == always["settle_steps"] / always["K"]
    assert np.isclose(always["steps_saved"], want, rtol=0, atol=1e-12)


def test_the_record_holds_the_rows(tmp_path):
    out = tmp_path / "settle.json"
    assert bench.main(["settle", "--sizes", "5", "--speeds", "1e9", "--samples", "2",
                       "--threads", "1", "--record", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["experiment"] == "settle_rest" and [r["n"] for r in d["rows"]] == [5]
    assert "git_commit" in d["provenance"]
