"""planners.svr_mpc.solve(settings, method, seed): the same call as planners.pick_place.solve,
and the same trial as the command line's row mapping (``experiments/mpc.py --rows``) gives."""

from dataclasses import replace

import pytest

from planners.svr_mpc import (
    DofSelection,
    Execution,
    SVRMPCSettings,
    Timing,
    parse_row,
    run_svr_mpc,
    solve,
    trial_params,
)
from planners.svr_mpc.experiments import mapping
from planners.svr_mpc.experiments.table1 import parse_args

BASE = SVRMPCSettings(task="clutter", timing=Timing(synchronous=True),
                      execution=Execution(timeout=3), threads=1)


#: rows spelled out by hand: Table 1 of the paper, the variants and fixes as documented
#: (+central: the authors' central differences, eps 1e-6)
ROWS = {"baseline": {"method": "baseline", "theta": 0, "rho": 1.0},
        "sum-t10-r1": {"method": "svr-sum", "theta": 10, "rho": 1.0},
        "svd-t5-r1+skip5+boxqp": {"method": "svr-svd", "theta": 5, "rho": 1.0,
                                  "keypoints": "skip", "fd_skip": 5, "box_qp": True},
        "sum-t10-r500+costdofs": {"method": "svr-sum", "theta": 10, "rho": 500.0,
                                  "keep_costed": True},
        "rand-t5+central": {"method": "rand", "theta": 5, "rho": 1.0, "fd_centered": True,
                            "fd_eps": 1e-6}}


@pytest.mark.parametrize("row", ROWS)
def test_a_row_sets_its_fields_and_the_command_line_agrees(row):
    """Row.apply sets exactly the row's fields over the settings (compared flat, as a trial's
    params keep them), and --rows makes the same settings of the row (every field but those
    the command line sets from its other flags)."""
    applied, plain = parse_row(row).apply(BASE).params(), BASE.params()
    changed = {k: v for k, v in applied.items() if plain[k] != v}
    expected = {k: v for k, v in ROWS[row].items() if plain[k] != v}
    assert changed == expected
    args = parse_args(["--task", "clutter", "--rows", row, "--trials", "1"])
    by_flags = mapping.settings_of(args, parse_row(row), feedback=False)
    base = mapping.base_settings(args)
    base = replace(base, execution=replace(base.execution, feedback=False))
    by_row = parse_row(row).apply(base)
    by_row = replace(by_row, timing=replace(by_row.timing, slowdown=by_flags.timing.slowdown),
                     threads=by_flags.threads)
    assert by_row == by_flags


def test_solve_runs_the_row_over_the_settings():
    """solve(settings, "sum-t10-r1", seed) is run_svr_mpc on the row's settings: the same
    cost, steps and |C| per optimisation (a synchronous episode is deterministic)."""
    a = solve(BASE, "sum-t10-r1", seed=2)
    b = run_svr_mpc(replace(BASE, selection=DofSelection("svr-sum", theta=10, rho=1.0)),
                    seed=2)
    assert (a.mpc_cost, a.steps, a.n_dofs) == (b.mpc_cost, b.steps, b.n_dofs)
    assert a.n_dofs[0] == 55 and min(a.n_dofs) < 55
    assert trial_params(parse_row("sum-t10-r1").apply(BASE), 2)["method"] == "svr-sum"


def test_solve_without_a_method_runs_the_settings_own_row():
    a, b = solve(BASE, seed=1), run_svr_mpc(BASE, seed=1)
    assert (a.mpc_cost, a.steps) == (b.mpc_cost, b.steps)


@pytest.mark.parametrize("method,error", [(3, TypeError), ("nope", ValueError)])
def test_solve_refuses_what_is_no_row(method, error):
    with pytest.raises(error, match="row"):
        solve(BASE, method, seed=0)


def test_the_preset_takes_its_task_first_and_the_protocol_by_name():
    """As PickPlaceSettings.preset(task, goal, protocol=): the protocol is keyword-only, so
    the older order (name first) fails loudly instead of reading "paper" as a task."""
    assert SVRMPCSettings.preset("soft", protocol="paper") == SVRMPCSettings.paper("soft")
    with pytest.raises(TypeError):
        SVRMPCSettings.preset("paper", "soft")          # the old order
