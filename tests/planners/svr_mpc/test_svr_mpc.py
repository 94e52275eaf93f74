"""planners.svr_mpc: Table 1 aggregation (pairing with baseline by seed, outliers, CI) and
one synchronous MPC episode from Python."""

import numpy as np
import pytest

from planners.svr_mpc import (
    TABLE1_ROWS,
    DofSelection,
    Execution,
    SVRMPCSettings,
    Timing,
    derivatives_effect,
    dofs_mask,
    dofs_of_mask,
    feedback_effect,
    legacy_trial_key,
    paired,
    row_name,
    run_svr_mpc,
    trial_key,
    trial_params,
)
from planners.svr_mpc import summarize as aggregate

SUM = "sum-t10-r1"     # the row of svr-sum at theta 10, rho 1


def short(method="baseline", timeout=3, synchronous=True, **timing) -> SVRMPCSettings:
    """A short episode of ``method`` on clutter on one thread."""
    return SVRMPCSettings(task="clutter", selection=DofSelection(method),
                          timing=Timing(synchronous=synchronous, **timing),
                          execution=Execution(timeout=timeout), threads=1)


def rec(method, seed, cost, dist=0.01):
    return {"params": {"method": method, "seed": seed, "rho": 1.0, "theta": 10},
            "result": {"mpc_cost": cost, "goal_distance_end": dist, "opt_ms_mean": 100.0,
                       "dofs_mean": 20.0, "success": dist < 0.02, "lag_steps_mean": 25.0}}


def test_pairs_by_seed_and_excludes_outliers():
    records = [rec("baseline", 0, 100.0), rec("baseline", 1, 200.0), rec("baseline", 2, 50.0),
               rec("svr-sum", 0, 50.0), rec("svr-sum", 1, 150.0),
               rec("svr-sum", 2, 5000.0, dist=1.8)]          # rolled away: an outlier
    out = aggregate(records)
    assert out["baseline"]["mpc_cost_normalised_mean"] == 1.0
    svr = out[SUM]
    assert svr["mpc_cost_normalised_mean"] == pytest.approx((0.5 + 0.75) / 2)
    assert svr["outliers"] == 1 and svr["n_trials"] == 3
    assert svr["mpc_cost_normalised_median"] == pytest.approx(0.75)   # over all three
    assert svr["mpc_cost_normalised_ci90"] > 0
    # the authors' statistic: median cost over baseline's median cost, unpaired
    assert svr["mpc_cost_median_ratio"] == pytest.approx(150.0 / 100.0)


def test_outlier_baseline_seed_is_not_a_reference():
    records = [rec("baseline", 0, 100.0, dist=2.0), rec("baseline", 1, 100.0),
               rec("naive", 0, 10.0), rec("naive", 1, 80.0)]
    out = aggregate(records)
    assert out["naive"]["mpc_cost_normalised_mean"] == pytest.approx(0.8)


def test_feedback_trials_get_their_own_rows_normalised_by_open_loop_baseline():
    records = [rec("baseline", 0, 100.0), rec("svr-sum", 0, 50.0), rec("svr-sum", 0, 40.0),
               rec("baseline", 0, 120.0)]
    records[2]["params"]["feedback"] = True
    records[3]["params"]["feedback"] = True
    out = aggregate(records)
    assert set(out) == {"baseline", "baseline +fb", SUM, SUM + " +fb"}
    assert out[SUM + " +fb"]["mpc_cost_normalised_mean"] == pytest.approx(0.4)
    assert out["baseline +fb"]["mpc_cost_normalised_mean"] == pytest.approx(1.2)
    on = aggregate(records[2:], baseline="baseline +fb")
    assert on[SUM + " +fb"]["mpc_cost_normalised_mean"] == pytest.approx(40 / 120)


def test_feedback_both_pairs_every_trial_back_to_back():
    from planners.svr_mpc.experiments import mapping, table1
    args = table1.parse_args(["--task", "clutter", "--rules", "baseline,svr-sum", "--trials",
                              "2", "--feedback", "both", "--slowdown", "1", "--out", "unused"])
    trials = mapping.make_trials(args)
    assert len(trials) == 8 and len({t.key for t in trials}) == 8
    # open loop, then the same trial with feedback
    for a, b in zip(trials[0::2], trials[1::2], strict=True):
        assert (a.params["feedback"], b.params["feedback"]) == (False, True)
        assert {k: v for k, v in a.params.items() if k != "feedback"} == \
            {k: v for k, v in b.params.items() if k != "feedback"}
    assert table1.parse_args(["--feedback", "--out", "x"]).feedback == "on"


def test_feedback_effect_is_the_paired_ratio():
    records = []
    for seed, (open_loop, fb) in enumerate([(100.0, 50.0), (100.0, 200.0), (80.0, 40.0)]):
        records += [rec("rand", seed, open_loop), rec("rand", seed, fb)]
        records[-1]["params"]["feedback"] = True
    records.append(rec("naive", 0, 10.0))                  # no pair: no entry
    out = feedback_effect(records)
    assert set(out) == {"rand-t10"}
    r = out["rand-t10"]
    assert r["ratio_geomean"] == pytest.approx((0.5 * 2.0 * 0.5) ** (1 / 3))
    assert r["ratio_ci90"][0] < r["ratio_geomean"] < r["ratio_ci90"][1]
    assert (r["better"], r["pairs"]) == (2, 3)


def test_derivatives_effect_pairs_each_variant_with_its_plain_row():
    """sum-t10-r1 +skip5 against sum-t10-r1 on the seeds both ran; feedback trials pair with
    feedback trials; a variant without a plain row has no entry."""
    records = []
    for seed, (plain, skip) in enumerate([(100.0, 50.0), (100.0, 200.0), (80.0, 40.0)]):
        records += [rec("svr-sum", seed, plain), rec("svr-sum", seed, skip)]
        records[-1]["params"].update(keypoints="skip", fd_skip=5)
        records[-1]["result"]["lag_steps_mean"] = 10.0
    records.append(rec("svr-sum", 7, 1.0))                         # no variant on seed 7
    records.append(rec("naive", 0, 10.0))
    records[-1]["params"].update(keypoints="adaptive")               # no plain naive row
    fb = rec("svr-sum", 0, 30.0)
    fb["params"].update(keypoints="skip", fd_skip=5, feedback=True)  # no plain +fb row
    central = rec("svr-sum", 0, 90.0)
    central["params"].update(fd_centered=True, fd_eps=1e-6)           # pairs with plain seed 0
    out = derivatives_effect([*records, fb, central])
    assert set(out) == {SUM + " +skip5", SUM + " +central"}
    assert out[SUM + " +central"]["ratio_geomean"] == pytest.approx(0.9)
    r = out[SUM + " +skip5"]
    assert r["versus"] == SUM and (r["better"], r["pairs"]) == (2, 3)
    assert r["ratio_geomean"] == pytest.approx((0.5 * 2.0 * 0.5) ** (1 / 3))
    assert (r["lag_steps_mean"], r["versus_lag_steps_mean"]) == (10.0, 25.0)


def test_one_synchronous_episode_from_python_is_deterministic():
    """run_svr_mpc wires task, cost, iLQR and selector in one call; the synchronous mode
    gives the same MPC cost twice, and the reduced method holds fewer DoFs than nv."""
    settings = short("svr-sum", timeout=4)
    a, b = run_svr_mpc(settings, seed=3), run_svr_mpc(settings, seed=3)
    assert a.mpc_cost == b.mpc_cost and a.steps == 4
    assert a.goal_distance_start > 0 and a.n_dofs[0] == 55
    assert min(a.n_dofs) < 55            # SVR dropped DoFs after the first optimisation


def test_settings_reject_unknown_names():
    with pytest.raises(ValueError, match="unknown task"):
        SVRMPCSettings(task="nope")
    with pytest.raises(ValueError, match="unknown method"):
        SVRMPCSettings(selection=DofSelection("svr"))


def test_paired_is_the_geometric_mean_of_per_seed_ratios():
    records = [rec("baseline", 0, 100.0), rec("baseline", 1, 100.0), rec("baseline", 2, 10.0),
               rec("svr-sum", 0, 50.0), rec("svr-sum", 1, 400.0), rec("svr-sum", 2, 5.0),
               rec("svr-sum", 3, 1.0)]                        # no baseline on seed 3
    r = paired(records)[SUM]
    assert r["pairs"] == 3 and r["better"] == 2
    assert r["ratio_geomean"] == pytest.approx((0.5 * 4.0 * 0.5) ** (1 / 3))
    assert r["ratio_ci90"][0] < r["ratio_geomean"] < r["ratio_ci90"][1]
    assert "baseline" not in paired(records)


def test_the_nine_table1_rows_parse_and_name_themselves():
    assert len(TABLE1_ROWS) == 9
    for name, (method, theta, rho) in TABLE1_ROWS.items():
        assert row_name(method, theta, rho) == name
        s = SVRMPCSettings.paper("clutter", name)
        assert s.selection == DofSelection(method, rho, theta)
        assert s.cost == "paper" and s.start.warm_start and s.timing.clock == "virtual"
        assert s.execution.control_noise == 0.05
    with pytest.raises(ValueError, match="unknown Table 1 row"):
        SVRMPCSettings.paper("clutter", "sum-t7-r3")


def test_dof_masks_round_trip():
    rng = np.random.default_rng(0)
    for nv in (1, 55, 154):
        dofs = np.sort(rng.choice(nv, size=rng.integers(1, nv + 1), replace=False))
        np.testing.assert_array_equal(dofs_of_mask(dofs_mask(dofs)), dofs)


def test_model_clock_episode_is_deterministic():
    """The model clock's lag does not depend on the machine: the same seed gives the same
    MPC cost bit for bit (control noise included)."""
    settings = SVRMPCSettings.paper("clutter", "sum-t10-r1", clock="model", timeout=40,
                                    threads=1)
    a, b = run_svr_mpc(settings, seed=2), run_svr_mpc(settings, seed=2)
    assert a.mpc_cost == b.mpc_cost and a.lag_steps == b.lag_steps and a.steps == 40
    assert a.active_sets == b.active_sets and a.clock == "model"


def test_a_fixed_model_clock_lags_every_row_alike():
    """clock_ms: every optimisation of every row lasts the same, so every row lags the same
    number of agent steps (what the fitted a + b |C| model would not give rows of other |C|);
    the trial key says so, and the duration is refused on another clock."""
    lags = {}
    for row in ("baseline", "rand-t5"):
        s = SVRMPCSettings.paper("clutter", row, clock="model", clock_ms=20.0, timeout=30,
                                 slowdown=1.0, threads=1)
        lags[row] = run_svr_mpc(s, seed=1).lag_steps
    assert len(set(lags["baseline"][1:] + lags["rand-t5"][1:])) == 1
    assert "ms20" in legacy_trial_key(trial_params(s, 1))
    with pytest.raises(ValueError, match="clock_ms"):
        SVRMPCSettings.paper("clutter", "baseline", clock_ms=20.0)       # the virtual clock
    with pytest.raises(ValueError, match="clock_ms"):
        SVRMPCSettings.paper("clutter", "baseline", clock="model", clock_ms=-1.0)


def test_unstable_trials_leave_the_mean_on_either_side_and_are_counted():
    records = [rec("baseline", 0, 100.0), rec("baseline", 1, 100.0), rec("baseline", 2, 100.0),
               rec("svr-sum", 0, 50.0), rec("svr-sum", 1, 70.0), rec("svr-sum", 2, 9.0)]
    records[5]["result"]["unstable"] = True            # its cost is no push's cost
    records[1]["result"]["unstable"] = True            # baseline seed 1: no reference
    out = aggregate(records)
    assert out[SUM]["mpc_cost_normalised_mean"] == pytest.approx(0.5)     # seed 0 only
    assert out[SUM]["n_unstable_trials"] == 1 and out["baseline"]["n_unstable_trials"] == 1
    assert out[SUM]["mpc_cost_normalised_median"] == pytest.approx(0.5)   # 0.09, 0.5, 0.7


def test_a_trial_captures_a_flagged_episode_under_the_sweeps_folder(tmp_path, monkeypatch):
    """run_trial with the sweep's folder (``CapturingTrial``): a speed bound the episode
    cannot keep flags its first step, and the capture lands in OUT/blowups/<trial key> at
    that step, listed in the result relative to OUT; a stable episode lists none; a rerun
    moves the old capture to OUT/blowups/outdated/."""
    import dataclasses
    import json

    import planners.svr_mpc.episode as episode
    from planners.svr_mpc import CapturingTrial

    params = trial_params(short(slowdown=1.0), 0)
    calm = CapturingTrial(str(tmp_path))(params)
    assert not calm["unstable"] and calm["blowups"] == []
    assert not (tmp_path / "blowups").exists()
    scene = episode.Scene
    monkeypatch.setattr(episode, "Scene", lambda model, stability: scene(
        model, stability=dataclasses.replace(stability, max_speed=1e-9)))
    res = CapturingTrial(str(tmp_path))(params)
    key = trial_key(params)                       # run_trial's capture label
    assert res["unstable"] and res["blowups"] == [f"blowups/{key}"]
    meta = json.loads((tmp_path / "blowups" / key / "blowup.json").read_text())
    assert res["unstable_reason"] == f"step {meta['step']}: {meta['reason']}"
    assert meta["label"] == key
    # a rerun of the trial (--fresh, or after a failure) retires the earlier capture
    assert CapturingTrial(str(tmp_path))(params)["blowups"] == [f"blowups/{key}"]
    assert (tmp_path / "blowups" / "outdated" / key / "blowup.json").is_file()


# ----------------------------------------------------------------- the optimiser seam
@pytest.fixture
def registry():
    """OPTIMISERS as it was after the test (a test registers its own)."""
    from planners.svr_mpc import OPTIMISERS

    saved = dict(OPTIMISERS)
    yield OPTIMISERS
    OPTIMISERS.clear()
    OPTIMISERS.update(saved)


class Constant:
    """An optimiser that plans ``u`` at every step on the DoF set ``dofs`` and counts its
    calls."""

    def __init__(self, u, dofs):
        self.u, self.dofs, self.calls = np.asarray(u, dtype=float), np.asarray(dofs), 0

    def optimise(self, state, plan):
        from dopt.mpc import Plan

        self.calls += 1
        return Plan(np.tile(self.u, (len(plan.controls), 1)), dofs=self.dofs)


def test_a_registered_optimiser_runs_the_episode(registry):
    """run_svr_mpc(optimiser=name) builds the optimiser from its factory (the task, scene,
    cost, service, settings and the episode's generator) and executes its plans: the agent's
    states are those of its controls rolled out from the start, every optimisation covers its
    DoF set, and run_trial runs it from a trial's params, under a key and row of its own."""
    from dopt.rollout import RolloutService
    from planners.svr_mpc import (
        OptimiserContext,
        register_optimiser,
        row_label,
        run_trial,
        trial_key,
        trial_params,
    )

    built = []

    def constant(context):
        assert isinstance(context, OptimiserContext)
        assert isinstance(context.settings, SVRMPCSettings)
        assert isinstance(context.rng, np.random.Generator)
        u = 0.3 * context.scene.model.actuator_ctrlrange[:, 1]
        built.append(Constant(u, context.task.robot_dofs[:3]))
        return built[-1]

    register_optimiser("constant", constant)
    settings = short(timeout=6, slowdown=1.0)
    res = run_svr_mpc(settings, seed=1, optimiser="constant")
    (opt,) = built
    assert opt.calls == len(res.opt_ms) >= 1 and res.steps == 6
    assert res.n_dofs == [3] * opt.calls
    assert set(res.active_sets) == {dofs_mask(opt.dofs)}
    task = settings.build_task(1)
    from dopt.scene import Scene

    scene = Scene(task.model, stability=task.stability)
    with RolloutService(scene) as service:
        states = service.trajectory(task.initial_state, np.tile(opt.u, (6, 1))).states
    np.testing.assert_allclose(res.final_state, states[-1], atol=1e-6)
    svr = run_svr_mpc(settings, seed=1)
    assert svr.mpc_cost != res.mpc_cost and svr.n_dofs[0] == 55

    params = trial_params(settings, 1, "constant")
    assert params["optimiser"] == "constant"
    assert legacy_trial_key(params).endswith("-optconstant")
    assert row_label(params) == "constant"
    assert row_label({**params, "method": "svr-sum", "theta": 10}) == "constant:sum-t10-r1"
    again = run_trial(params)
    assert again["mpc_cost"] == res.mpc_cost and again["final_state"] == res.final_state
    # the default optimiser adds nothing to the params: the paper's trials keep their keys
    plain = trial_params(settings, 1)
    assert "optimiser" not in plain and legacy_trial_key(plain) == legacy_trial_key(params)[
        :-len("-optconstant")]
    assert trial_key(plain) != trial_key(params)
    assert trial_key(plain).rsplit("-", 1)[0] == trial_key(params).rsplit("-", 1)[0]


def test_a_factory_runs_without_a_name_and_summaries_give_it_a_row():
    """A factory passed as such needs no registry; a registered optimiser's trials summarise
    as a row of their own, normalised by the baseline trials on the same seeds."""
    settings = short()
    res = run_svr_mpc(settings, seed=0,
                      optimiser=lambda c: Constant(np.zeros(c.scene.nu), [0, 1]))
    assert res.n_dofs == [2] * len(res.opt_ms)
    records = [rec("baseline", 0, 100.0), rec("baseline", 1, 200.0),
               rec("baseline", 0, 50.0), rec("baseline", 1, 300.0)]
    for r in records[2:]:
        r["params"]["optimiser"] = "constant"
    out = aggregate(records)
    assert set(out) == {"baseline", "constant"}
    assert out["constant"]["mpc_cost_normalised_mean"] == pytest.approx((0.5 + 1.5) / 2)


def test_unoptimised_executes_the_first_plan_padded_with_its_last_control():
    """The built-in ``unoptimised`` optimiser changes nothing: the executed controls are the
    episode's first plan (the warm-started push plan) and then its last control repeated,
    whatever the lag, and it optimises no DoF."""
    from planners.svr_mpc.episode import start_and_plan

    settings = short(timeout=100, synchronous=False)
    res = run_svr_mpc(settings, seed=2, optimiser="unoptimised", keep_controls=True)
    task = settings.build_task(2)
    start, plan = start_and_plan(settings, task, task.model.nu)
    T = len(plan.controls)
    assert T < res.steps == 100                     # the padding is exercised
    expected = plan.controls[np.minimum(np.arange(res.steps), T - 1)]
    np.testing.assert_array_equal(np.asarray(res.controls), expected)
    np.testing.assert_array_equal(np.asarray(res.start_state), start)
    assert set(res.n_dofs) == {0} and len(res.opt_ms) >= 1


def test_history_needs_an_optimiser_that_keeps_one():
    settings = short(timeout=2)
    with pytest.raises(TypeError, match="history needs an optimiser that keeps one"):
        run_svr_mpc(settings, 0, history=[],
                    optimiser=lambda c: Constant(np.zeros(c.scene.nu), [0]))


def test_modules_named_by_the_environment_register_their_optimisers(registry, tmp_path,
                                                                    monkeypatch):
    """DOPT_OPTIMISERS: the modules are imported before a name is looked up, so a command
    line's --rows (parse_row) and a spawned worker's run_trial know their optimisers."""
    import sys

    from planners.svr_mpc import parse_row

    (tmp_path / "plugged_optimisers.py").write_text(
        "from planners.svr_mpc import register_optimiser, svr_optimiser\n"
        "register_optimiser('plugged', svr_optimiser)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "plugged_optimisers", raising=False)
    with pytest.raises(ValueError, match="unknown Table 1 row 'plugged'"):
        parse_row("plugged")
    monkeypatch.setenv("DOPT_OPTIMISERS", "plugged_optimisers")
    row = parse_row("plugged+boxqp")
    assert (row.method, row.optimiser, row.variants) == ("baseline", "plugged",
                                                         {"box_qp": True})
    monkeypatch.setenv("DOPT_OPTIMISERS", "no_such_module_here")
    assert parse_row("sum-t10-r1").optimiser == "svr"         # a Table 1 row looks none up
    with pytest.raises(ValueError, match="DOPT_OPTIMISERS: cannot import 'no_such_module"):
        parse_row("nope")


# ------------------------------------------------------------ typed derivative options
def test_derivatives_are_typed_fields_of_the_settings():
    """Derivatives is the settings' ``derivatives`` and their five flat fields in a trial's
    params; its defaults are the settings' own; a row's variants parse once into its
    fields."""
    from dataclasses import replace

    from planners.svr_mpc import Derivatives, parse_variants

    plain = SVRMPCSettings().params()
    assert {k: plain[k] for k in Derivatives().fields()} == Derivatives().fields()
    d = Derivatives(fd="central", keypoints="skip", fd_skip=5, box_qp=True)
    assert d.fields() == {"fd_centered": True, "fd_eps": 1e-6, "keypoints": "skip",
                          "fd_skip": 5, "box_qp": True}
    s = replace(SVRMPCSettings(), derivatives=d)
    assert SVRMPCSettings().with_params(**d.fields()) == s
    assert {k: trial_params(s, 0)[k] for k in d.fields()} == d.fields()
    how = s.ilqr.derivatives
    assert (how.fd_config.centered, how.fd_config.eps, how.keypoint_config.skip, how.box_qp) == \
        (True, 1e-6, 5, True)
    assert parse_variants(["central", "skip5", "boxqp"]) == {
        "fd": "central", "keypoints": "skip", "fd_skip": 5, "box_qp": True}
    assert replace(Derivatives(), **parse_variants(["central", "skip5", "boxqp"])) == d
    assert parse_variants(["adaptive"]) == {"keypoints": "adaptive", "fd_skip": 1}
