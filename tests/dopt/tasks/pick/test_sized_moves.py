"""Moves sized per sample (``PickerConfig.move = "sized"``): each action's move lasts as long
as its own displacement takes at the picker's speed, at least ``min_move``, at most the fixed
move; a batch of mixed lengths gives each sample the trajectory it has alone, bit for bit, at
any thread count; an executed plan replays to its recorded final state; the fixed move, the
default, is what it was."""

from dataclasses import replace

import numpy as np
import pytest

from dopt.rollout import RolloutConfig, RolloutService, share_cores
from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth
from dopt.tasks.pick.picker import CONTROL_SPEC, NONE, PickerConfig
from dopt.tasks.pick.replay import replay
from dopt.tasks.pick.scene import PickPlaceTask
from dopt.tasks.pick.settle import RestTest

BOUND = 0.3
SIZED = PickerConfig(bound=(BOUND,) * 3, move="sized")
FIXED = replace(SIZED, move="fixed")

#: four samples of two actions whose moves differ: a None and a middling move, the longest move
#: and a middling one, a tiny move and a None, two middling ones
PARTICLES = np.array([[NONE, 5], [35, 0], [0, NONE], [14, 20]])
DISPLACEMENTS = np.array([[[0.0, 0.0, 0.0], [0.15, 0.0, 0.1]],
                          [[-BOUND, BOUND, BOUND], [0.1, 0.1, 0.0]],
                          [[0.01, 0.0, 0.0], [0.0, 0.0, 0.0]],
                          [[-0.2, 0.1, 0.1], [0.0, -0.15, 0.05]]])


@pytest.fixture(scope="module")
def cloth():
    return make_cloth(ClothSceneConfig(n=6), SIZED)


@pytest.fixture(scope="module")
def fixed_cloth():
    return make_cloth(ClothSceneConfig(n=6), FIXED)


def _service(scene, threads=1):
    return RolloutService(scene.scene, RolloutConfig(threads=threads))


def test_a_zero_move_gets_the_minimum_and_the_longest_the_fixed_length(cloth):
    pk = cloth.picker
    shortest = int(np.ceil(SIZED.min_move / pk.dt))
    assert 2 <= shortest < pk.move_steps
    assert pk.moves(np.zeros(3)) == shortest
    assert pk.moves([0.0, 0.0, 1e-4]) == shortest
    # the bound box's diagonal takes the fixed move, and nothing takes longer
    assert pk.moves([BOUND, -BOUND, BOUND]) == pk.move_steps
    rng = np.random.default_rng(0)
    d = rng.uniform(-BOUND, BOUND, (200, 3))
    n = pk.moves(d)
    assert n.shape == (200,) and n.min() >= shortest and n.max() <= pk.move_steps
    # in between: |d| at the picker's average speed, in whole steps
    norm = np.linalg.norm(d, axis=1)
    mid = (norm / SIZED.speed > SIZED.min_move)
    assert np.array_equal(n[mid], np.ceil(norm[mid] / SIZED.speed / pk.dt).astype(int))
    assert np.all(np.diff(n[np.argsort(norm)]) >= 0)              # longer moves, more steps


def test_the_fixed_move_is_every_actions_and_the_default(cloth, fixed_cloth):
    assert PickerConfig().move == "fixed"
    pk = fixed_cloth.picker
    plan = pk.schedule(PARTICLES, DISPLACEMENTS)
    assert np.all(plan.steps == pk.steps_per_action)
    assert np.all(plan.lengths == 2 * pk.steps_per_action)
    assert plan.controls.shape == (4, 2 * pk.steps_per_action, pk.ncontrol)
    # the same config but the move rule: the same K, and a sized action never longer
    assert cloth.picker.steps_per_action == pk.steps_per_action
    sized = cloth.picker.schedule(PARTICLES, DISPLACEMENTS)
    assert np.all(sized.steps <= pk.steps_per_action) and sized.steps.min() < pk.steps_per_action
    assert sized.lengths.tolist() == sized.steps.sum(axis=1).tolist()
    assert sized.controls.shape[1] == sized.lengths.max()


def test_an_actions_rows_hold_its_grasp_and_its_whole_displacement(cloth):
    pk = cloth.picker
    plan = pk.schedule(PARTICLES, DISPLACEMENTS)
    back_p, back_d = pk.decode(plan.controls, horizon=2)
    assert np.array_equal(back_p, PARTICLES)
    np.testing.assert_allclose(back_d, DISPLACEMENTS, atol=1e-12)
    # a sequence's padding is idle rows
    p = int(np.argmin(plan.lengths))
    assert np.all(plan.controls[p, plan.lengths[p]:] == pk.idle_row)
    with pytest.raises(ValueError, match="horizon"):
        pk.decode(plan.controls)


def test_a_mixed_batch_gives_each_sample_its_trajectory_alone(cloth):
    """Every state after every step of each sample, in a batch of four with different
    lengths, equals that sample's alone, bit for bit; its later records repeat its last."""
    spec = cloth.scene.layout.spec
    plan = cloth.picker.schedule(PARTICLES, DISPLACEMENTS)
    assert len(set(plan.lengths.tolist())) == 4
    with _service(cloth, threads=2) as svc:
        batch = svc.rollout(cloth.initial_state, plan.controls, control_spec=CONTROL_SPEC,
                            record=(spec,), lengths=plan.lengths)
        for p in range(len(PARTICLES)):
            own = cloth.picker.schedule(PARTICLES[p:p + 1], DISPLACEMENTS[p:p + 1])
            assert own.controls.shape[1] == plan.lengths[p]
            assert np.array_equal(own.controls[0], plan.controls[p, :plan.lengths[p]])
            alone = svc.rollout(cloth.initial_state, own.controls, control_spec=CONTROL_SPEC,
                                record=(spec,))
            T = plan.lengths[p]
            assert np.array_equal(batch.records[spec][p, :T], alone.records[spec][0])
            assert np.all(batch.records[spec][p, T:] == alone.records[spec][0, -1])
            assert np.array_equal(batch.final_states[p], alone.final_states[0])
            for field in ("unstable", "step", "max_speed", "max_strain", "max_energy_gain"):
                assert getattr(batch.stability, field)[p] == \
                    getattr(alone.stability, field)[0], field


@pytest.mark.parametrize("move", ["sized", "fixed"])
def test_threads_give_the_results_of_one_thread(cloth, fixed_cloth, move):
    scene = cloth if move == "sized" else fixed_cloth
    goal = scene.positions(scene.initial_state)
    rng = np.random.default_rng(1)
    particles = rng.integers(-1, scene.n_particles, (7, 2))
    displacements = rng.uniform(-BOUND, BOUND, (7, 2, 3)) * [1, 1, 0.5] + [0, 0, 0.15]
    results = {}
    for threads in (1, 2, 3):
        with _service(scene, threads) as svc:
            task = PickPlaceTask(scene, goal, rollout=svc)
            results[threads] = (task.rollout(particles, displacements),
                                task.evaluate(particles, displacements), task.n_steps)
    one, costs, steps = results[1]
    for threads in (2, 3):
        res, c, s = results[threads]
        assert np.array_equal(res.final_states, one.final_states)
        assert np.array_equal(c, costs) and s == steps
        assert np.array_equal(res.stability.step, one.stability.step)
        assert np.array_equal(res.stability.max_strain, one.stability.max_strain)


def test_evaluate_counts_each_samples_own_steps(cloth):
    with _service(cloth) as svc:
        task = PickPlaceTask(cloth, cloth.positions(cloth.initial_state), rollout=svc)
        task.evaluate(PARTICLES, DISPLACEMENTS)
    plan = cloth.picker.schedule(PARTICLES, DISPLACEMENTS)
    assert task.n_steps == plan.lengths.sum() < task.n_full_steps
    assert task.n_full_steps == PARTICLES.size * cloth.picker.steps_per_action


def test_a_replayed_plan_ends_where_its_execution_did(cloth):
    """The executed plan (``execute``: the rollout service) and its replay (plain mj_step,
    ``dopt.tasks.pick.replay``) take the same steps of each action."""
    task = PickPlaceTask(cloth, cloth.positions(cloth.initial_state), rollout=_service(cloth))
    particles, displacements = PARTICLES[3], DISPLACEMENTS[3]
    first = task.execute(particles[:1], displacements[:1])
    final = task.execute(particles[1:], displacements[1:], start=first.state).state
    actions = [{"particles": particles[:1].tolist(), "displacements": displacements[:1].tolist()},
               {"particles": particles[1:].tolist(), "displacements": displacements[1:].tolist()}]
    rep = replay(cloth, cloth.initial_state, actions, max_frames=30)
    np.testing.assert_array_equal(rep.states[-1], final)
    assert rep.step[-1] == cloth.picker.schedule(particles[None], displacements[None]).lengths[0]
    assert rep.stage[-1] == 1 and rep.action[-1] == 0


def test_a_trial_with_sized_moves_replays_to_its_recorded_final_state():
    """A quick cloth trial planned and executed with --move sized: the recorded actions,
    replayed with plain mj_step, end on the recorded final state, and the trial's steps per
    CEM sample are fewer than the fixed move's."""
    from planners.pick_place import PickPlaceSettings, make_problem, solve

    s = replace(PickPlaceSettings.preset("cloth", "diagonal", quick=True), picker_move="sized",
                threads=1)
    result = solve(s, "simple", seed=0)
    problem = make_problem(s, 0)
    rep = replay(problem.scene, problem.start_state, result.actions, max_frames=10)
    np.testing.assert_array_equal(rep.states[-1], result.final_state)
    H = sum(len(a["particles"]) for a in result.actions)
    assert rep.step[-1] < H * problem.scene.picker.steps_per_action


def test_bad_move_settings_name_their_field(cloth):
    with pytest.raises(ValueError, match="PickerConfig.move"):
        PickerConfig(move="slow")
    with pytest.raises(ValueError, match="PickerConfig.min_move"):
        PickerConfig(move="sized", min_move=0.0)
    with pytest.raises(TypeError, match="PickerConfig.move"):
        PickerConfig(move=1)
    with pytest.raises(ValueError, match="rest"):
        PickPlaceTask(cloth, cloth.positions(cloth.initial_state), rest=RestTest())


@pytest.mark.parametrize("lengths, error", [
    ([0, 5], ValueError), ([5, 11], ValueError), ([5], ValueError), ([[5, 5]], ValueError),
    ([5.0, 5.0], TypeError)])
def test_bad_lengths_name_the_argument(cloth, lengths, error):
    u = np.tile(cloth.picker.idle_row, (2, 10, 1))
    with _service(cloth) as svc, pytest.raises(error, match="lengths"):
        svc.rollout(cloth.initial_state, u, control_spec=CONTROL_SPEC, lengths=lengths)


def test_share_cores_gives_one_trial_every_core_and_a_sweep_one_thread_each():
    assert share_cores(1, cores=8) == 0                  # RolloutConfig: every core
    assert share_cores(2, cores=8) == 4 and share_cores(3, cores=8) == 2
    assert share_cores(2, cores=2) == 1 and share_cores(5, cores=2) == 1
    with pytest.raises(ValueError, match="concurrent"):
        share_cores(0)
