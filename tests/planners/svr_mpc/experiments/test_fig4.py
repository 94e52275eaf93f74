"""experiments/rho_sweep.py (Fig. 4, planners.svr_mpc.experiments.fig4): a tiny grid end to
end, with the authors' curves."""

import json
import os
import subprocess
import sys
from pathlib import Path

from planners.svr_mpc.experiments import fig4, runner

ROOT = Path(__file__).resolve().parents[4]


def test_tiny_grid_writes_points_and_the_plot_with_the_authors_curves(tmp_path):
    paper = tmp_path / "paper.json"
    paper.write_text(json.dumps({"tasks": {"clutter": {"fig4": [
        {"theta": 0, "rho": 0.0, "median_ratio": 1.0, "avg_dofs": 55.0},
        {"theta": 0, "rho": 1.0, "median_ratio": 0.9, "avg_dofs": 9.0}]}}}))
    out = tmp_path / "rho"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, str(ROOT / "experiments" / "rho_sweep.py"),
                           "--preset", "paper", "--rhos", "0,1", "--thetas", "0",
                           "--trials", "1", "--timeout", "30", "--paper-reference", str(paper),
                           "--out", str(out)], capture_output=True, text=True, env=env,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    d = json.loads((out / "summary.json").read_text())
    assert [(p["rho"], p["theta"]) for p in d["points"]] == [(0.0, 0), (1.0, 0)]
    for p in d["points"]:
        assert p["n_trials"] == 1 and p["n_dofs_mean"] > 0 and "mpc_cost_median_ratio" in p
    assert d["points"][0]["n_dofs_mean"] == 55.0          # rho 0 keeps every DoF
    # the protocol and every SVRMPCSettings field of each row (the stale check's)
    assert d["preset"] == "paper" and d["cost"] == "paper" and d["clock"] == "virtual"
    assert set(d["settings"]) == {"baseline", "sum-t0-r0", "sum-t0-r1"}
    assert d["settings"]["sum-t0-r1"]["control_noise"] == 0.05
    assert "seed" not in d["settings"]["baseline"]
    assert (out / "rho_sweep.png").stat().st_size > 10_000
    # every point against the baseline, one Holm family; one scene gives no test
    assert d["versus"]["family_size"] == 2 and d["versus"]["references"] == ["baseline"]
    assert {x["verdict"] for x in d["versus"]["pairs"].values()} == {"no difference shown"}


def test_the_sweep_runs_scene_by_scene(tmp_path, monkeypatch, capsys):
    """Trials run seed by seed, each seed's baseline with its grid points, so a sweep stopped
    part way holds every point on the same first scenes."""
    seen = []

    def fake_run(args, trials, *a, **k):
        seen.extend((t.params["seed"], t.params["method"]) for t in trials)
        raise RuntimeError("stopped after ordering")

    monkeypatch.setattr(runner, "run", fake_run)
    rc = fig4.main(["--preset", "paper", "--rhos", "0,1", "--thetas", "0,5",
                    "--trials", "3", "--out", str(tmp_path / "rho")])
    assert rc != 0 and "stopped after ordering" in capsys.readouterr().err
    seeds = [s for s, _ in seen]
    assert seeds == sorted(seeds) and len(seen) == 3 * (1 + 4)
    assert [m for s, m in seen if s == 0] == ["baseline"] + ["svr-sum"] * 4
