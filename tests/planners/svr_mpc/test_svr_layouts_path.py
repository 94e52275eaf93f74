"""The authors' clutter scenes folder (``PushScene.layouts``) is recorded relative to the
checkout's root (issue 93: a result names no folder of its machine) and read back from there,
whatever the current folder of the process that rebuilds the settings from a trial's params."""

import os

import pytest

from dopt.lab.provenance import repo_root, rooted
from planners.svr_mpc import SVRMPCSettings
from planners.svr_mpc.settings import split_params, trial_params


def test_layouts_are_recorded_relative_to_the_root_and_read_back_from_any_folder(
        tmp_path, monkeypatch):
    layouts = tmp_path / "push_mcl_layouts"
    layouts.mkdir()
    s = SVRMPCSettings.authors("clutter", layouts=str(layouts))
    assert not os.path.isabs(s.scene.layouts)
    assert os.path.normpath(os.path.join(repo_root(), s.scene.layouts)) == str(layouts)
    monkeypatch.chdir(layouts)               # a worker elsewhere rebuilds it from its params
    again, seed, _ = split_params(trial_params(s, 3))
    assert (again, seed) == (s, 3) and rooted(again.scene.layouts) == layouts
    assert SVRMPCSettings.authors("clutter", layouts=".").scene.layouts == s.scene.layouts
    older, _, _ = split_params({**trial_params(s, 0), "layouts": str(layouts)})
    assert older.scene.layouts == str(layouts)                       # an old record
    assert rooted(older.scene.layouts) == layouts


def test_a_missing_layouts_folder_is_named_as_this_machine_sees_it(tmp_path):
    gone = tmp_path / "gone"
    with pytest.raises(ValueError, match=f"layouts: no folder {gone} "):
        SVRMPCSettings.authors("clutter", layouts=str(gone))
