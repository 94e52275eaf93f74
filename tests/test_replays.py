"""The committed replayable MPC episodes (docs/results/runs/replays-<task>/: one episode per
Table 1 row and the unoptimised push plan on each of the authors' tasks, seed 0, ``--preset
authors --keep-controls``) open in dopt-view's MPC source and replay to their recorded final
states, each the row the run was asked for."""

import json
from pathlib import Path

import numpy as np
import pytest

from dopt.lab.trialpack import stored_trials
from dopt.view.episode import collect
from planners.svr_mpc import TABLE1_ROWS, row_label
from planners.view import MPC

ROOT = Path(__file__).resolve().parents[1]
RUNS = ROOT / "docs" / "results" / "runs"
TASKS = ("clutter", "soft", "soft_rigid")
#: the authors' clutter scenes the clutter episodes were run on (the params name this path,
#: relative to the repository root)
LAYOUTS = Path("../shared/external/ilqr_svr/push_mcl_layouts")


def _trials(task: str) -> list:
    folder = RUNS / f"replays-{task}" / "trials"
    assert folder.is_dir(), f"no committed replays of {task} ({folder})"
    return stored_trials(folder)


@pytest.mark.parametrize("task", TASKS)
def test_one_episode_per_row_of_table1_and_the_unoptimised_plan(task):
    records = [json.loads(t.read_text()) for t in _trials(task)]
    labels = [row_label(r["params"]) for r in records]
    assert sorted(labels) == sorted([*TABLE1_ROWS, "unoptimised"])
    for r in records:
        p = r["params"]
        assert p["task"] == task and p["seed"] == 0 and p["problem"] == "authors"
        assert p["clock"] == "authors" and p["timeout"] is None          # the task's own Y
        assert len(r["result"]["controls"]) == r["result"]["steps"] > 0
        assert not str((r.get("code") or {}).get("commit", "")).endswith("dirty")


@pytest.mark.parametrize("task", TASKS)
def test_each_opens_in_the_viewer_and_replays_to_its_recorded_final_state(task, monkeypatch):
    if task == "clutter":
        if not (ROOT / LAYOUTS).is_dir():
            pytest.skip(f"the authors' clutter scenes are not at {LAYOUTS} (../shared)")
        monkeypatch.chdir(ROOT)                # the params name the scenes from the root
    found = collect(RUNS / f"replays-{task}")
    assert len(found) == len(TABLE1_ROWS) + 1
    for label, (source, path) in found.items():
        assert source is MPC, label
        episode = MPC.load(path, max_frames=20)
        record = json.loads(path.read_text() if path.is_file() else
                            next(t for t in _trials(task) if t.stem == label).read_text())
        assert episode.replay_error is not None and episode.replay_error <= 1e-9, label
        final = np.asarray(record["result"]["final_state"], dtype=float)
        assert np.abs(episode.states[-1] - final).max() <= 1e-9, label
