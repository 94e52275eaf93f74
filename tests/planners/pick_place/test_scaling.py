"""The gain against the particle count (``planners.pick_place.scaling``): the trend test finds a
gap that grows with log N and none in a flat one; the 20 x 20 trials of the committed Fig. 7
sweep are trials of the scaling run (same keys); the command line's bad flags exit 2 with one
error line."""

from pathlib import Path

import numpy as np
import pytest

from dopt.lab.trialpack import stored_trials
from dopt.tasks import make_cloth
from planners.pick_place import PickPlaceSettings, trial_key
from planners.pick_place.experiments.sweep import SCHEMA
from planners.pick_place.scaling import (
    NO_TREND,
    flat_cost,
    scaling_settings,
    scaling_summary,
    scaling_trials,
)

ROOT = Path(__file__).resolve().parents[3]
SIZES = (10, 15, 20, 30)


def records(gap_per_log_n: float, seeds: int = 6, noise: float = 1e-3) -> list[dict]:
    """Sweep records of simple / original / random at ``SIZES``: Simple's cost 10 mm, the
    others' ``gap_per_log_n * log N`` above it (random: half of it) plus seeded noise (m)."""
    rng = np.random.default_rng(0)
    out = []
    for n in SIZES:
        for s in range(seeds):
            gap = gap_per_log_n * np.log(n * n)
            for m, cost in (("simple", 0.01), ("original", 0.01 + gap),
                            ("random", 0.01 + gap / 2)):
                out.append({"params": {"settings": {"n": n}, "method": m, "seed": s},
                            "result": {"final_cost": float(cost + rng.normal(0, noise)),
                                       "unstable": False}})
    return out


def test_growing_gap_has_a_positive_slope():
    out = scaling_summary(records(0.004))
    t = out["trend"]["original_minus_simple"]
    assert t["slope"] == pytest.approx(0.004, abs=1e-3)
    assert t["slope"] - t["slope_ci95"] > 0 and t["p_holm"] < 0.05
    assert t["verdict"] == "grows" and out["trend"]["random_minus_simple"]["verdict"] == "grows"
    assert out["sizes"] == list(SIZES) and out["n_particles"] == [n * n for n in SIZES]
    size = out["per_size"]["20"]
    assert size["methods"]["simple"]["n"] == 6 and size["methods"]["simple"]["final_cost_ci95"]
    assert size["original_minus_simple"]["seeds"] == list(range(6))
    assert size["original_minus_simple"]["mean"] == pytest.approx(0.004 * np.log(400),
                                                                  abs=2e-3)
    assert "original - simple grows" in out["verdict"]


def test_flat_gap_has_no_trend():
    out = scaling_summary(records(0.0))
    for t in out["trend"].values():
        assert t["verdict"] == NO_TREND
        assert t["slope"] - t["slope_ci95"] <= 0 <= t["slope"] + t["slope_ci95"]


def test_unstable_and_unpaired_trials_are_left_out():
    recs = records(0.004, seeds=3)
    recs[0]["result"]["unstable"] = True                     # n 10, seed 0, simple
    out = scaling_summary(recs)
    assert out["per_size"]["10"]["methods"]["simple"]["seeds"] == [1, 2]
    assert out["per_size"]["10"]["original_minus_simple"]["seeds"] == [1, 2]


def test_one_size_is_no_trend():
    out = scaling_summary([r for r in records(0.004) if r["params"]["settings"]["n"] == 20])
    assert out["trend"]["original_minus_simple"]["slope"] is None
    assert out["trend"]["original_minus_simple"]["verdict"] == NO_TREND


@pytest.mark.parametrize("goal", ["diagonal", "side"])
def test_committed_20x20_trials_are_the_scaling_trials(goal):
    folder = ROOT / "docs" / "results" / "runs" / f"fig7-cloth-{goal}" / "trials"
    if not folder.is_dir():
        pytest.skip(f"no committed trials under {folder}")
    committed = {t.stem for t in stored_trials(folder)}
    cem = {k for k in committed if not k.startswith("scripted-")}
    seeds = range(len(cem) // 3)
    trials = scaling_trials(goal, [20], seeds, ["simple", "original", "random"])
    # stored under their older names, which the sweep's schema finds (Schema.aliases)
    assert {SCHEMA.aliases_of(t.params)[0] for t in trials} == cem
    assert not {t.key for t in trials} & committed
    assert all(t.params["settings"]["physics"] == "default" for t in trials)
    other = scaling_trials(goal, [10, 20], seeds, ["simple", "original", "random"])
    assert len(other) == 2 * len(trials) and len({t.key for t in other}) == len(other)


@pytest.mark.parametrize("argv, flag", [
    (["--goal", "reflective"], "--goal"),
    (["--goal", "diagonal", "--sizes", "2,10"], "--sizes"),
    (["--goal", "diagonal", "--sizes", "10,10"], "--sizes"),
    (["--goal", "diagonal", "--methods", "original,random"], "--methods"),
    (["--goal", "diagonal", "--seeds", "0"], "--seeds"),
    (["--goal", "diagonal", "--reuse-from", "/nonexistent/fig7"], "--reuse-from"),
    (["--goal", "diagonal", "--mode", "spacing"], "--mode"),
])
def test_bad_flags_exit_2_with_one_line(argv, flag, tmp_path, capsys):
    from planners.pick_place.experiments import scaling as fig7_scaling

    with pytest.raises(SystemExit) as exc:
        fig7_scaling.main([*argv, "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert exc.value.code == 2, err
    errors = [line for line in err.splitlines() if "error:" in line]
    assert len(errors) == 1 and flag in errors[0] and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_the_size_sweep_keeps_density_and_relative_reach_fixed():
    """Mode "size": every sheet at the 20 x 20 preset's spacing, its mass per area, picker's
    bound and workspace per side those of the preset, its CEM budget the preset's; at n = 20
    the preset itself (the Fig. 7 trials' keys). Mass and spacing read back from MuJoCo."""
    preset = PickPlaceSettings.preset("cloth", "side", protocol="paper")
    spacing, density = preset.side / (preset.n - 1), preset.scene_config().mass / preset.side ** 2
    for n in (10, 15, 20, 25, 30):
        s = scaling_settings("side", n, mode="size")
        assert s.n == n and s.cem == preset.cem and s.physics == preset.physics
        assert s.scene_config().spacing == pytest.approx(spacing, rel=1e-12)
        assert s.scene_config().mass / s.side ** 2 == pytest.approx(density, rel=1e-12)
        assert s.bound / s.side == pytest.approx(preset.bound / preset.side, rel=1e-12)
        box = np.array(s.constraint().high[:2]) - s.constraint().low[:2]
        assert box / s.side == pytest.approx(2.0, rel=1e-12)
        assert s.scene_config().particle_radius == pytest.approx(
            preset.scene_config().particle_radius, rel=1e-12)
    assert scaling_settings("side", 20, mode="size") == scaling_settings("side", 20) == preset
    assert trial_key("simple", 0, scaling_settings("side", 20, mode="size")) == \
        trial_key("simple", 0, preset)
    for n in (10, 25):
        s = scaling_settings("side", n, mode="size")
        scene = make_cloth(s.scene_config(), s.picker())
        m = scene.model
        bodies = m.flex_vertbodyid[m.flex_vertadr[0]:][:n * n]
        assert m.body_mass[bodies].sum() / s.side ** 2 == pytest.approx(density, rel=1e-6)
        p = scene.positions(scene.initial_state)
        assert np.ptp(p[:, 0]) == pytest.approx((n - 1) * spacing, rel=1e-3)
    with pytest.raises(ValueError, match="scaling mode"):
        scaling_settings("side", 10, mode="spacing")
    with pytest.raises(ValueError, match="mass"):
        PickPlaceSettings.preset("rope", "fold").__class__(
            **{**PickPlaceSettings.preset("rope", "fold").__dict__, "mass": 0.1})


def test_flat_cost_is_the_folds_travel_and_grows_with_the_side():
    """The side fold moves half the sheet from x to about -x: a mean distance of side / 4 over
    the whole sheet, less the rounded crease's share; the diagonal's is side * 2 sqrt(2) / 12
    (the moving triangle's mean distance to the crease, doubled, over two)."""
    for n in (10, 20, 25):
        s = scaling_settings("side", n, mode="size")
        assert flat_cost(s) == pytest.approx(s.side / 4, rel=0.06)
        d = scaling_settings("diagonal", n, mode="size")
        assert flat_cost(d) == pytest.approx(d.side * 2 * np.sqrt(2) / 12, rel=0.1)


def test_the_normalised_statistics_divide_by_the_flat_cost():
    recs = records(0.004)
    flat = {n: 0.01 * n for n in SIZES}
    out = scaling_summary(recs, flat)
    plain = scaling_summary(recs)
    assert out["trend"] == plain["trend"] and out["verdict"] == plain["verdict"]
    for n in SIZES:
        e, p = out["per_size"][str(n)], plain["per_size"][str(n)]
        assert e["flat_cost"] == flat[n]
        simple = e["methods"]["simple"]
        assert simple["final_cost_normalised_mean"] == pytest.approx(
            p["methods"]["simple"]["final_cost_mean"] / flat[n])
        assert e["original_minus_simple_normalised"]["values"] == pytest.approx(
            [v / flat[n] for v in p["original_minus_simple"]["values"]])
    # a gap that grows as log N in m shrinks once divided by a flat cost that grows as n
    assert out["trend_normalised"]["original_minus_simple"]["slope"] < 0
    assert "of the flat cost" in out["verdict_normalised"]
    with pytest.raises(ValueError, match="flat_costs"):
        scaling_summary(recs, {10: 0.1})
