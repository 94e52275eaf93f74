"""The key-particle experiments' stale check imports today's presets (no snapshot): what it
compares with is every preset the library resolves, and every result that records only preset
names finds what they meant at its commit in docs/results/presets/at-commit.json."""

from dataclasses import asdict
from pathlib import Path

import pytest

from dopt.lab.report.base import load_results
from dopt.lab.report.stale import base_commit
from planners.pick_place.experiments.report_stale import (
    AT_COMMIT,
    _at_commits,
    needs_backfill,
    today,
)

ROOT = Path(__file__).resolve().parents[4]
RESULTS = ROOT / "docs" / "results"


def test_every_result_that_records_only_preset_names_has_its_commits_presets():
    """Every result that records only preset names has its commit's presets in the record
    (else the report calls it "not checked")."""
    need = {base_commit(r.origin.get("git_commit")) for r in load_results(RESULTS)
            if needs_backfill(r)}
    at = _at_commits(str(RESULTS))
    assert (RESULTS / AT_COMMIT).is_file()
    assert need <= set(at), sorted(need - set(at))
    for c in need:
        assert "error" not in at[c]["pick"]["physics"], (c, at[c]["pick"]["physics"])


def test_today_is_every_preset_the_library_resolves():
    """Against the library's own tables: every physics preset of both scenes with every field
    of its config, every protocol's budget of every registered goal."""
    pytest.importorskip("torch")
    pytest.importorskip("mujoco")
    import planners.pick_place as pp
    from dopt.tasks.pick.cloth_scene import PHYSICS_PRESETS, ClothSceneConfig

    t = today()
    assert set(t["physics"]["cloth"]) == set(PHYSICS_PRESETS)
    for name in PHYSICS_PRESETS:
        assert set(t["physics"]["cloth"][name]) == set(asdict(ClothSceneConfig.physics(name)))
    assert set(t["protocols"]) == set(pp.PROTOCOLS) == set(t["resolved"])
    for task, goals in pp.GOALS.items():
        for goal in goals:
            s = pp.PickPlaceSettings.preset(task, goal, protocol="paper")
            assert t["protocols"]["paper"][f"{task}/{goal}"]["cem"]["iterations"] == \
                s.cem.iterations
            assert "threads" not in t["protocols"]["paper"][f"{task}/{goal}"]
