"""A pick-and-place trial stopped anywhere and resumed from its checkpoint gives the result of
the trial that was never stopped (the rollouts, both generators and the counters carry over),
on a two-stage fold with CEM(Random), whose candidates come from the numpy generator and whose
samples from the torch one."""

from dataclasses import replace

import pytest

from planners.pick_place import PickPlaceSettings, ScriptedPlanner, make_problem, run_problem, solve
from planners.trial_progress import iterations_done
from tests.planners.checkpoints import MemoryCheckpoint, Stop

#: what a resumed trial may differ in: its wall time (summed over its runs), the mean seconds
#: per CEM iteration (measured in two runs) and the number of runs
TIMINGS = ("wall_s", "s_per_iteration", "segments")


@pytest.fixture(scope="module")
def settings():
    s = PickPlaceSettings.preset("cloth", "reflective", quick=True)
    return replace(s, cem=replace(s.cem, population=4, elites=2))


@pytest.fixture(scope="module")
def uninterrupted(settings):
    return solve(settings, "random", 3).to_dict()


# two stages of two CEM iterations: saves 1-2 are the first stage's iterations, 3 its end,
# 4-5 the second stage's iterations, 6 the trial's end
@pytest.mark.parametrize("stop_after", [1, 3, 4])
def test_a_trial_stopped_anywhere_resumes_to_the_same_result(settings, uninterrupted,
                                                             stop_after):
    checkpoint, seen = MemoryCheckpoint(stop_after), []
    with pytest.raises(Stop):
        solve(settings, "random", 3, lambda i, best: seen.append(i), checkpoint=checkpoint)
    # the progress holds the iterations run before the stop, and the resume runs the others
    assert iterations_done(checkpoint.saved) == len(seen)
    resumed = solve(settings, "random", 3, lambda i, best: seen.append(i),
                    checkpoint=checkpoint).to_dict()
    assert len(seen) == len(uninterrupted["cost_history"])
    assert checkpoint.saves == 6                 # each save once: the resume goes on after it
    assert resumed["segments"] == 2
    assert {k: v for k, v in resumed.items() if k not in TIMINGS} == \
        {k: v for k, v in uninterrupted.items() if k not in TIMINGS}


def test_the_progress_of_another_trial_is_refused(settings):
    checkpoint = MemoryCheckpoint(stop_after=1)
    with pytest.raises(Stop):
        solve(settings, "random", 3, checkpoint=checkpoint)
    with pytest.raises(ValueError, match="another trial: seed 3, not 4"):
        solve(settings, "random", 4, checkpoint=checkpoint)
    with pytest.raises(ValueError, match="another trial: method 'random', not 'simple'"):
        solve(settings, "simple", 3, checkpoint=checkpoint)
    with pytest.raises(ValueError, match="other settings: bound"):
        solve(replace(settings, bound=0.2), "random", 3, checkpoint=checkpoint)
    # threads do not change a trial's result: its progress resumes with other threads
    assert solve(replace(settings, threads=2), "random", 3,
                 checkpoint=checkpoint).segments == 2


def test_the_progress_of_physics_that_resolved_otherwise_is_refused(settings):
    # the same settings, saved when their physics preset meant another scene (as after a
    # preset's change): the progress is not resumed on today's scene
    checkpoint = MemoryCheckpoint(stop_after=1)
    with pytest.raises(Stop):
        solve(settings, "random", 3, checkpoint=checkpoint)
    scene = checkpoint.saved["trial"]["settings"]["resolved"]["scene"]
    scene["damping"] = 2 * scene["damping"] + 1.0
    with pytest.raises(ValueError, match="other settings: resolved"):
        solve(settings, "random", 3, checkpoint=checkpoint)


def test_a_planner_without_rng_state_runs_without_checkpoints(settings):
    checkpoint = MemoryCheckpoint()
    res = run_problem(make_problem(settings), ScriptedPlanner(settings.scripted),
                      checkpoint=checkpoint)
    assert checkpoint.saves == 0 and res.segments == 1


def test_a_checkpoint_without_load_and_save_is_a_type_error(settings):
    with pytest.raises(TypeError, match="checkpoint must have load"):
        solve(settings, "random", 3, checkpoint="progress.json")
