"""docs/results/presets/resolved.json is what today's presets resolve to (the stale check of
experiments/report.py compares every result with it), and it says what the presets meant at
the commit of every result that records only their names."""

import json
from pathlib import Path

import pytest
from report_base import load_results
from report_stale import SNAPSHOT, base_commit, needs_backfill

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "docs" / "results"


def committed() -> dict:
    return json.loads((RESULTS / SNAPSHOT).read_text())


def test_the_snapshot_holds_the_presets_at_every_commit_the_results_need():
    """Standard library: every result that records only preset names has its commit's
    presets in the snapshot (else the report calls it "not checked")."""
    need = {base_commit(r.origin.get("git_commit")) for r in load_results(RESULTS)
            if needs_backfill(r)}
    at = committed()["at_commit"]
    assert need <= set(at), sorted(need - set(at))
    for c in need:
        assert "error" not in at[c]["pick"]["physics"], (c, at[c]["pick"]["physics"])


def test_the_snapshot_is_what_todays_presets_resolve_to():
    """A preset changed in the code fails here until `python experiments/presets_snapshot.py`
    rewrites the file; the report then flags the results recorded on the old fields."""
    pytest.importorskip("torch")
    pytest.importorskip("mujoco")
    import presets_snapshot

    snap = committed()
    assert json.loads(json.dumps(presets_snapshot.svr_presets())) == snap["svr_mpc"], \
        "run `python experiments/presets_snapshot.py`"
    assert json.loads(json.dumps(presets_snapshot.pick_presets())) == snap["pick"], \
        "run `python experiments/presets_snapshot.py`"
