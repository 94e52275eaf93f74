"""Push tasks registered as specs (dopt.tasks.PUSH_TASKS): their constants read without
compiling a model, and equal to what a built instance (ours, and the authors' soft scenes)
says of itself, MuJoCo's own model fields included."""

import mujoco
import numpy as np
import pytest

from dopt.tasks import AUTHORS_PUSH_TASKS, PUSH_TASKS, PushTaskSpec, TaskModel, get_task
from planners.svr_mpc import task_defaults

FIELDS = ("horizon", "dt", "timeout", "slowdown")


def _no_models(monkeypatch):
    """Every route to a compiled model raises."""
    def refuse(*args, **kwargs):
        raise AssertionError("a model was compiled")

    monkeypatch.setattr(mujoco.MjSpec, "compile", refuse)
    monkeypatch.setattr(mujoco.MjModel, "from_xml_string", refuse)
    monkeypatch.setattr(mujoco.MjModel, "from_xml_path", refuse)


@pytest.fixture(scope="module", params=sorted(PUSH_TASKS))
def built(request):
    """(the task's name, our instance of it drawn from seed 3)."""
    return request.param, PUSH_TASKS[request.param](np.random.default_rng(3))


def test_defaults_build_no_model_and_equal_a_built_task(built, monkeypatch):
    name, task = built
    _no_models(monkeypatch)
    with pytest.raises(AssertionError, match="compiled"):
        get_task(name)(np.random.default_rng(0))           # the patch does bite
    spec = get_task(name)
    read = task_defaults(name)
    assert read == (float(task.slowdown), int(task.timeout))
    assert isinstance(spec, PushTaskSpec) and spec.name == task.name == name
    assert tuple(getattr(spec, f) for f in FIELDS) == tuple(getattr(task, f) for f in FIELDS)
    assert spec.nv == task.model.nv
    assert spec.dt == task.model.opt.timestep


@pytest.mark.parametrize("name", ["soft", "soft_rigid"])
def test_the_authors_soft_scenes_share_the_specs_constants(name):
    task = AUTHORS_PUSH_TASKS[name](np.random.default_rng(1))
    spec = PUSH_TASKS[name]
    assert isinstance(task, TaskModel) and task.name == name
    assert tuple(getattr(spec, f) for f in FIELDS) == tuple(getattr(task, f) for f in FIELDS)
    assert task.model.nv == spec.nv


@pytest.mark.parametrize("change, error, match", [
    (dict(horizon=0), ValueError, "PushTaskSpec.horizon must be > 0"),
    (dict(nv=55.0), TypeError, "PushTaskSpec.nv must be an int"),
    (dict(dt=float("nan")), ValueError, "PushTaskSpec.dt must be finite"),
    (dict(name=""), ValueError, "PushTaskSpec.name must be a non-empty str"),
    (dict(build="clutter"), TypeError, "PushTaskSpec.build must be callable"),
])
def test_a_bad_spec_is_refused_naming_the_field(change, error, match):
    fields = dict(name="mine", horizon=10, dt=0.01, timeout=100, slowdown=1, nv=9,
                  build=PUSH_TASKS["clutter"].build)
    with pytest.raises(error, match=match):
        PushTaskSpec(**{**fields, **change})
