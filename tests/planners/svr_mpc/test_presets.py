"""The SVR protocols as a table with sources (planners.svr_mpc.presets): every preset and row
resolves to the settings and trial params it resolved to before the table, field by field."""

from dataclasses import fields

import pytest

from dopt.tasks import PUSH_TASKS
from planners.svr_mpc import PRESETS, TABLE1_ROWS, SVRMPCSettings, trial_key, trial_params
from planners.svr_mpc.presets import AUTHORS, PAPER, PROTOCOLS, Setting, protocol_fields
from planners.svr_mpc.settings import RECORD_NAMES

#: the reference: the rows and protocols as SVRMPCSettings.paper / .authors spelled them out
#: before the table (main at 9e1480e), flat as a trial's params keep them, and the paper's
#: Table 1 headings
OLD_ROWS = {"baseline": ("baseline", 0, 1.0), "rand-t5": ("rand", 5, 1.0),
            "naive": ("naive", 0, 1.0), "svd-t10-r1": ("svr-svd", 10, 1.0),
            "svd-t10-r500": ("svr-svd", 10, 500.0), "svd-t5-r1": ("svr-svd", 5, 1.0),
            "sum-t10-r1": ("svr-sum", 10, 1.0), "sum-t10-r500": ("svr-sum", 10, 500.0),
            "sum-t5-r1": ("svr-sum", 5, 1.0)}


def _old_paper(task, row="sum-t10-r1", **overrides):
    method, theta, rho = OLD_ROWS[row]
    return SVRMPCSettings.from_params({
        "task": task, "method": method, "theta": theta, "rho": rho,
        "cost": {"soft": "paper-reach"}.get(task, "paper"), "warm_start": True,
        "control_noise": 0.05, "clock": "virtual", **overrides})


def _old_authors(task, row="sum-t10-r1", layouts=None, **overrides):
    return _old_paper(task, row, **{"problem": "authors", "layouts": layouts,
                                    "cost": f"authors-{task}", "control_noise": 0.0,
                                    "executor": "authors", "clock": "authors", **overrides})


@pytest.fixture
def layouts(tmp_path, monkeypatch):
    """A folder standing in for the authors' scenes, named relative to the current folder."""
    (tmp_path / "push_mcl_layouts").mkdir()
    monkeypatch.chdir(tmp_path)
    return "push_mcl_layouts"


def _same(new, old):
    for f in fields(SVRMPCSettings):
        assert getattr(new, f.name) == getattr(old, f.name), f.name
    paced = {"slowdown": 2.0}                       # what the command lines fill in
    new_p = trial_params(new.with_params(**paced), 4)
    old_p = trial_params(old.with_params(**paced), 4)
    assert new_p == old_p and trial_key(new_p) == trial_key(old_p)


@pytest.mark.parametrize("task", sorted(PUSH_TASKS))
@pytest.mark.parametrize("row", list(OLD_ROWS))
def test_every_protocol_and_row_resolves_as_before(task, row, layouts):
    assert list(TABLE1_ROWS) == list(OLD_ROWS) and TABLE1_ROWS[row] == OLD_ROWS[row]
    where = layouts if task == "clutter" else None
    _same(SVRMPCSettings.paper(task, row), _old_paper(task, row))
    _same(SVRMPCSettings.paper(task, row, timeout=7, threads=1),
          _old_paper(task, row, timeout=7, threads=1))
    _same(SVRMPCSettings.authors(task, row, layouts=where),
          _old_authors(task, row,
                       SVRMPCSettings.authors(task, row, layouts=where).scene.layouts))
    _same(SVRMPCSettings.authors(task, row, layouts=where, executor="alg1"),
          _old_authors(task, row, SVRMPCSettings.authors(task, row, layouts=where).scene.layouts,
                       executor="alg1"))


@pytest.mark.parametrize("task", sorted(PUSH_TASKS))
def test_presets_by_name(task, layouts):
    assert PRESETS == ("ours", "paper", "authors") == tuple(PROTOCOLS)
    _same(SVRMPCSettings.preset(task), SVRMPCSettings(task=task))
    _same(SVRMPCSettings.preset(task, protocol="paper"), _old_paper(task))
    where = layouts if task == "clutter" else None
    new = SVRMPCSettings.preset(task, protocol="authors", layouts=where)
    _same(new, _old_authors(task, layouts=new.scene.layouts))
    with pytest.raises(ValueError, match="unknown preset 'nope'"):
        SVRMPCSettings.preset(task, protocol="nope")
    with pytest.raises(ValueError, match="only preset 'authors' reads them"):
        SVRMPCSettings.preset(task, protocol="paper", layouts="push_mcl_layouts")


def test_every_number_names_its_source_and_a_settings_field():
    for table in (PAPER, AUTHORS):
        for field, setting in table.items():
            assert field in RECORD_NAMES                 # a setting by its flat name
            assert isinstance(setting, Setting) and len(setting.source) > 20
    for task in PUSH_TASKS:                          # every task resolves to a known value
        SVRMPCSettings.from_params({"task": task, **{
            k: v for k, v in protocol_fields("authors", task).items() if k != "problem"}})
    with pytest.raises(ValueError, match="Setting.source must name where"):
        Setting(1.0, "")
    with pytest.raises(ValueError, match="unknown Table 1 row 'sum-t1'"):
        SVRMPCSettings.paper("clutter", "sum-t1")
