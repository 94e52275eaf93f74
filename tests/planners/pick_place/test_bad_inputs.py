"""Every bad input of the pick-and-place pipeline gets a clear error naming the argument, before
any scene is built: the settings' fields and dicts, the pipeline's calls, and the sizes the
settings imply (the planners' own: tests/planners/test_bad_inputs_cem.py)."""

import numpy as np
import pytest

from planners.cem import CEMConfig
from planners.pick_place import (
    CEMPlanner,
    PickPlaceSettings,
    ScriptedPlanner,
    make_planner,
    make_problem,
    run_problem,
    solve,
)

CEM_SMALL = CEMConfig(population=4, elites=1, iterations=1, horizon=1)
ROPE = dict(task="rope", goal="fold", n=20, bound=0.1, cem=CEM_SMALL)


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(task="Rope"), ValueError, "unknown task 'Rope'"),
    (dict(task=None), ValueError, "unknown task None"),
    (dict(goal="diagonal"), ValueError, "unknown rope goal 'diagonal'"),
    (dict(n=2), ValueError, "PickPlaceSettings.n.*>= 3"),
    (dict(n=20.0), TypeError, "PickPlaceSettings.n.*int"),
    (dict(n=True), TypeError, "PickPlaceSettings.n.*int"),
    (dict(n="20"), TypeError, "PickPlaceSettings.n.*int"),
    (dict(bound=np.nan), ValueError, "PickPlaceSettings.bound.*finite"),
    (dict(bound=np.inf), ValueError, "PickPlaceSettings.bound.*finite"),
    (dict(bound=0.0), ValueError, "PickPlaceSettings.bound.*> 0"),
    (dict(bound=-0.1), ValueError, "PickPlaceSettings.bound.*> 0"),
    (dict(bound="0.1"), TypeError, "PickPlaceSettings.bound.*number"),
    (dict(bound=None), TypeError, "PickPlaceSettings.bound.*number"),
    (dict(bound=True), TypeError, "PickPlaceSettings.bound.*number"),
    (dict(bound=[0.1]), TypeError, "PickPlaceSettings.bound.*number"),
    (dict(threads=-1), ValueError, "PickPlaceSettings.threads.*>= 0"),
    (dict(threads=1.5), TypeError, "PickPlaceSettings.threads.*int"),
    (dict(threads=None), TypeError, "PickPlaceSettings.threads.*int"),
    (dict(cem=None), TypeError, "PickPlaceSettings.cem must be a CEMConfig"),
    (dict(cem={}), TypeError, "PickPlaceSettings.cem must be a CEMConfig"),
    (dict(scripted=None), TypeError, "PickPlaceSettings.scripted must be a ScriptedConfig"),
    (dict(selfcollide=1), TypeError, "PickPlaceSettings.selfcollide.*bool"),
    (dict(side=np.nan), ValueError, "PickPlaceSettings.side.*finite"),
    (dict(side=-0.3), ValueError, "PickPlaceSettings.side.*> 0"),
    (dict(length=0.0), ValueError, "PickPlaceSettings.length.*> 0"),
    (dict(length="x"), TypeError, "PickPlaceSettings.length.*number"),
])
def test_pick_place_settings_fields(kwargs, error, match):
    with pytest.raises(error, match=match):
        PickPlaceSettings(**{**ROPE, **kwargs})


def test_pick_place_settings_normalise_numpy_scalars():
    s = PickPlaceSettings(**{**ROPE, "n": np.int64(20), "bound": np.float32(0.1)})
    assert type(s.n) is int and type(s.bound) is float
    assert PickPlaceSettings.from_dict(s.to_dict()) == s


@pytest.mark.parametrize("d, error, match", [
    ({"task": "rope"}, ValueError, r"settings does not match PickPlaceSettings: missing "
                                   r"\['bound', 'cem', 'goal', 'n'\]"),
    ("extra", ValueError, r"unknown \['foo'\]"),
    ("cem extra", ValueError, r"settings\['cem'\] does not match CEMConfig: unknown \['pop'\]"),
    ([1, 2], TypeError, "from_dict needs a dict"),
])
def test_pick_place_settings_from_dict(d, error, match):
    good = PickPlaceSettings(**ROPE).to_dict()
    if d == "extra":
        d = {**good, "foo": 1}
    elif d == "cem extra":
        d = {**good, "cem": {**good["cem"], "pop": 3}}
    with pytest.raises(error, match=match):
        PickPlaceSettings.from_dict(d)


@pytest.mark.parametrize("call, error, match", [
    (lambda s: PickPlaceSettings.preset("rope", "diagonal"), ValueError, "no preset"),
    (lambda s: PickPlaceSettings.preset("rope", "fold", quick="yes"), TypeError,
     "quick.*bool"),
    (lambda s: make_planner("Simple", s), ValueError, "unknown method 'Simple'"),
    (lambda s: make_planner(None, s), ValueError, "unknown method None"),
    (lambda s: make_planner("simple", None), TypeError, "settings must be PickPlaceSettings"),
    (lambda s: make_planner("simple", s, -1), ValueError, "seed.*>= 0"),
    (lambda s: make_planner("simple", s, 1.5), TypeError, "seed.*int"),
    (lambda s: make_planner("simple", s, "0"), TypeError, "seed.*int"),
    (lambda s: make_planner("simple", s, True), TypeError, "seed.*int"),
    (lambda s: make_planner("simple", s, 2 ** 70), ValueError, r"seed must be < 2\*\*63"),
    (lambda s: make_problem(s, -1), ValueError, "seed.*>= 0"),
    (lambda s: make_problem({"task": "rope"}), TypeError, "settings must be PickPlaceSettings"),
    (lambda s: solve({"task": "rope"}), TypeError, "settings must be PickPlaceSettings"),
    (lambda s: solve(s, "bogus"), ValueError, "unknown method 'bogus'"),
    (lambda s: solve(s, "simple", -3), ValueError, "seed.*>= 0"),
    (lambda s: solve(s, "simple", 0.5), TypeError, "seed.*int"),
    (lambda s: solve(s, "simple", 0, on_iteration=3), TypeError, "on_iteration must be"),
    (lambda s: solve(s, "simple", 0, blowup_out=3), TypeError, "blowup_out must be"),
    (lambda s: solve(s, "simple", 0, blowup_label=7), TypeError, "blowup_label must be"),
    (lambda s: run_problem(None, make_planner("simple", s)), TypeError,
     "problem must be a Problem"),
    (lambda s: CEMPlanner(s.cem, "every", 0), ValueError, "candidates must be one of"),
    (lambda s: CEMPlanner(None, "keys", 0), TypeError, "config must be a CEMConfig"),
    (lambda s: CEMPlanner(s.cem, "keys", -1), ValueError, "seed.*>= 0"),
    (lambda s: ScriptedPlanner(None), TypeError, "config must be a ScriptedConfig"),
])
def test_pick_place_calls(call, error, match):
    """Each raises before any scene is built (a float seed used to run a whole trial)."""
    with pytest.raises(error, match=match):
        call(PickPlaceSettings(**ROPE))




def test_make_problem_checks_the_sizes_its_settings_imply_before_building_anything():
    """A cloth of 100000 x 100000 particles once ended in a MemoryError of numpy; the
    settings' sizes are checked first, naming the setting (``planners.pick_place.budget``)."""
    from dataclasses import replace

    from planners.pick_place.budget import BudgetError, budget_problem

    cloth = PickPlaceSettings.preset("cloth", "diagonal")
    with pytest.raises(BudgetError, match=r"on 10000000000 particles\) needs about .* more "
                                          r"than this machine's memory") as exc:
        make_problem(replace(cloth, n=100_000))
    assert exc.value.field == "n"
    rope = PickPlaceSettings.preset("rope", "fold")
    assert budget_problem(rope) is None
    assert budget_problem(replace(rope, bound=1e9)).field == "bound"
    assert budget_problem(replace(rope, picker_speed=1e-9)).field == "picker_speed"
    assert budget_problem(replace(rope, cem=replace(rope.cem, population=10**9))).field == \
        "cem.population"
