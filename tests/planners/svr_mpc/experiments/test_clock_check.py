"""experiments/clock_check.py: the comparison of the two clocks' trials."""

import pytest

from planners.svr_mpc.experiments import clock_check, flags


def rec(clock, seed, lag, opt_ms, cost):
    return {"params": {"method": "svr-sum", "theta": 10, "rho": 1.0, "seed": seed,
                       "clock": clock},
            "result": {"lag_steps_mean": lag, "opt_ms_mean": opt_ms, "mpc_cost": cost}}


def test_ratios_and_verdicts():
    records = {"real": [rec("real", 0, 20.0, 80.0, 100.0), rec("real", 1, 22.0, 88.0, 110.0)],
               "virtual": [rec("virtual", 0, 21.0, 84.0, 104.0),
                           rec("virtual", 1, 23.0, 92.0, 108.0)]}
    row = clock_check.compare(records, 2.0)["sum-t10-r1"]
    assert row["lag_ratio"] == pytest.approx(22.0 / 21.0)
    assert row["opt_ms_ratio"] == pytest.approx(88.0 / 84.0)
    # one thread's CPU time is 2 x the virtual time: 2 x 88 over the real 84 ms
    assert row["real_speedup"] == pytest.approx(2.0 * 88.0 / 84.0)
    assert row["lag_within_10_percent"] and row["cost_intervals_overlap"]
    assert row["real"]["n_trials"] == 2
    records["virtual"] = [rec("virtual", 0, 30.0, 84.0, 1000.0),
                          rec("virtual", 1, 31.0, 92.0, 1001.0)]
    row = clock_check.compare(records, 2.0)["sum-t10-r1"]
    assert not row["lag_within_10_percent"] and not row["cost_intervals_overlap"]


def test_trials_differ_only_in_clock_and_threads(tmp_path):
    args = flags.parse_args(
        ["--preset", "paper", "--rows", "baseline", "--trials", "1", "--out", str(tmp_path)],
        clock_check.parser())
    (real,), (virtual,) = (clock_check.clock_trials(args, c) for c in ("real", "virtual"))
    diff = {k for k in real.params if real.params[k] != virtual.params[k]}
    assert diff == {"clock", "threads"} and real.params["threads"] == 2
    assert real.key != virtual.key
