"""The gain against the particle count (``planners.pick_place.scaling``): the trend test finds a
gap that grows with log N and none in a flat one; the 20 x 20 trials of the committed Fig. 7
sweep are trials of the scaling run (same keys); the command line's bad flags exit 2 with one
error line."""

from pathlib import Path

import numpy as np
import pytest

from dopt.trialpack import stored_trials
from planners.pick_place.scaling import NO_TREND, scaling_summary, scaling_trials

ROOT = Path(__file__).resolve().parents[2]
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
def test_committed_20x20_trials_have_the_scaling_keys(goal):
    folder = ROOT / "docs" / "results" / "runs" / f"fig7-cloth-{goal}" / "trials"
    if not folder.is_dir():
        pytest.skip(f"no committed trials under {folder}")
    committed = {t.stem for t in stored_trials(folder)}
    cem = {k for k in committed if not k.startswith("scripted-")}
    seeds = range(len(cem) // 3)
    trials = scaling_trials(goal, [20], seeds, ["simple", "original", "random"])
    assert {t.key for t in trials} == cem
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
])
def test_bad_flags_exit_2_with_one_line(argv, flag, tmp_path, capsys):
    import fig7_scaling

    with pytest.raises(SystemExit) as exc:
        fig7_scaling.main([*argv, "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert exc.value.code == 2, err
    errors = [line for line in err.splitlines() if "error:" in line]
    assert len(errors) == 1 and flag in errors[0] and "Traceback" not in err
    assert not (tmp_path / "out").exists()
