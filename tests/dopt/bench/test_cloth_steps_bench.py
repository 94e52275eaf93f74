"""python -m dopt.bench cloth-steps: its rows add up and name what it measured."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from dopt.bench.cloth_steps import bench_cloth_steps

ROOT = Path(__file__).resolve().parents[3]


def test_rows_split_the_step_into_stages_that_add_up():
    rows = bench_cloth_steps([6, 8], ["default"])
    assert [(r["preset"], r["n"], r["particles"]) for r in rows] == \
        [("default", 6, 36), ("default", 8, 64)]
    for r in rows:
        ms = r["ms_per_step"]
        parts = ms["position"] + ms["velocity"] + ms["actuation"] + ms["constraint_solve"]
        assert ms["step"] > 0 and ms["other"] == pytest.approx(ms["step"] - parts)
        assert ms["kinematics"] + ms["collision"] <= ms["position"] + 1e-9
        assert r["steps_per_action"] > 0
        assert r["ms_per_action"] == pytest.approx(ms["step"] * r["steps_per_action"])
        assert r["fields"]["timestep"] > 0 and isinstance(r["messages"], dict)


def test_record_writes_a_result_file(tmp_path):
    out = tmp_path / "steps.json"
    proc = subprocess.run([sys.executable, "-m", "dopt.bench", "cloth-steps", "--sizes", "6",
                           "--presets", "default", "--record", str(out)], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    d = json.loads(out.read_text())
    assert d["experiment"] == "cloth_steps" and len(d["rows"]) == 1
    assert "git_commit" in d["provenance"]


def test_a_variant_changes_its_fields_and_reports_the_flex_solve_residual(monkeypatch):
    """MuJoCo's flex solve of the discrete integrator runs at most ``iterations`` iterations to
    ``tolerance``: one iteration to 1e-12 runs out on an 8 x 8 sheet, the warning's residual is
    recorded and lies above the tolerance; the preset's own row converges."""
    from dopt.bench import cloth_steps
    monkeypatch.setitem(cloth_steps.VARIANTS, "one iteration",
                        {"iterations": 1, "tolerance": 1e-12})
    plain, starved = bench_cloth_steps([8], ["default"], ["one iteration"])
    assert (plain["variant"], starved["variant"]) == (None, "one iteration")
    assert plain["flex_solve_residual_max"] is None and not plain["warnings"]
    assert starved["fields"]["iterations"] == 1 and starved["fields"]["tolerance"] == 1e-12
    assert starved["flex_solve_residual_max"] > 1e-12
    assert starved["warnings"].get("mjWARN_INERTIA", 0) > 0


def test_unknown_variant_is_named():
    with pytest.raises(ValueError, match="no such thing"):
        bench_cloth_steps([6], ["default"], ["no such thing"])
