"""Settle until at rest (dopt.tasks.pick.settle): with a rest speed nothing reaches, the staged
rollout is bit-identical to the plain one; with one everything reaches, every sample stops at
its first test and ends where a plain rollout of the cut rows ends; a sample that stopped early
was at rest; the merged verdict against a brute-force merge; bad inputs."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dopt.rollout import RolloutConfig, RolloutService
from dopt.stability import Stability
from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth
from dopt.tasks.pick.picker import CONTROL_SPEC
from dopt.tasks.pick.scene import PickPlaceTask
from dopt.tasks.pick.settle import RestTest, _Merged, rollout_until_rest


@pytest.fixture(scope="module")
def cloth():
    return make_cloth(ClothSceneConfig(n=6))


@pytest.fixture(scope="module")
def service(cloth):
    with RolloutService(cloth.scene, RolloutConfig(threads=1)) as svc:
        yield svc


def _actions(cloth, P, H, seed):
    g = np.random.default_rng(seed)
    idx = g.choice(cloth.picker.pickable, (P, H))
    idx[0, 0] = -1                                          # a None action among them
    return idx, g.uniform(-0.08, 0.08, (P, H, 3))


def _rms(cloth, states):
    v = states[:, cloth.scene.layout["qvel"]][:, cloth.velocity_dofs]
    return np.sqrt((v ** 2).sum(-1).mean(-1))


def test_speed_zero_is_the_plain_rollout_bit_for_bit(cloth, service):
    idx, d = _actions(cloth, 5, 2, 0)
    plain = service.rollout(cloth.initial_state, cloth.picker.encode(idx, d),
                            control_spec=CONTROL_SPEC)
    rested = rollout_until_rest(service, cloth.picker, cloth.velocity_dofs, cloth.initial_state,
                                idx, d, RestTest(speed=0.0, check_every=0.02))
    assert np.array_equal(rested.result.final_states, plain.final_states)
    assert np.array_equal(rested.steps, np.full(5, 2 * cloth.picker.steps_per_action))
    assert rested.full_steps == 2 * cloth.picker.steps_per_action
    a, b = rested.result.stability, plain.stability
    for name in ("unstable", "step", "max_speed", "max_penetration", "max_strain",
                 "capped_steps"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


def test_a_speed_everything_reaches_stops_each_action_at_its_first_test(cloth, service):
    """The reference: each action's rows cut after move + min_settle, run action by action."""
    pk = cloth.picker
    rest = RestTest(speed=1e9, min_settle=0.01)
    idx, d = _actions(cloth, 4, 2, 1)
    rested = rollout_until_rest(service, pk, cloth.velocity_dofs, cloth.initial_state, idx, d,
                                rest)
    keep = pk.steps_per_action - pk.settle_steps + int(round(0.01 / pk.dt))
    U = pk.encode(idx, d).reshape(4, 2, pk.steps_per_action, -1)
    x = np.repeat(cloth.initial_state[None], 4, axis=0)
    for h in range(2):
        x = service.rollout(x, U[:, h, :keep], control_spec=CONTROL_SPEC).final_states
    assert np.array_equal(rested.result.final_states, x)
    assert np.array_equal(rested.steps, np.full(4, 2 * keep))


def test_a_sample_that_stopped_early_was_at_rest_and_one_that_did_not_ran_it_all(cloth,
                                                                                 service):
    pk = cloth.picker
    idx, d = _actions(cloth, 8, 1, 2)
    rest = RestTest(speed=0.005)
    rested = rollout_until_rest(service, pk, cloth.velocity_dofs, cloth.initial_state, idx, d,
                                rest)
    rms = _rms(cloth, rested.result.final_states)
    early = rested.steps < pk.steps_per_action
    assert early.any() and not early.all(), rested.steps      # both kinds in this draw
    assert np.all(rms[early] < rest.speed)
    assert np.all(rested.steps[~early] == pk.steps_per_action)
    chunk = int(round(rest.check_every / pk.dt))
    first = pk.steps_per_action - pk.settle_steps + int(round(rest.min_settle / pk.dt))
    assert np.all((rested.steps[early] - first) % chunk == 0)


def test_evaluate_counts_the_steps_and_matches_the_plain_costs_at_speed_zero(cloth, service):
    goal = cloth.positions(cloth.initial_state)
    idx, d = _actions(cloth, 4, 1, 3)
    plain = PickPlaceTask(cloth, goal, rollout=service)
    never = PickPlaceTask(cloth, goal, rollout=service, rest=RestTest(speed=0.0))
    always = PickPlaceTask(cloth, goal, rollout=service, rest=RestTest(speed=1e9))
    assert np.array_equal(plain.evaluate(idx, d), never.evaluate(idx, d))
    always.evaluate(idx, d)
    K = cloth.picker.steps_per_action
    assert plain.n_steps == plain.n_full_steps == never.n_steps == 4 * K
    assert always.n_full_steps == 4 * K and always.n_steps < 4 * K


def _verdict(unstable, step, maxima, capped):
    P = len(unstable)
    return Stability(unstable=np.array(unstable), step=np.array(step),
                     reason=tuple(f"r{s}" if u else ""
                                  for u, s in zip(unstable, step, strict=True)),
                     max_speed=np.array(maxima[0]), max_penetration=np.array(maxima[1]),
                     max_strain=np.array(maxima[2]), capped_steps=np.array(capped),
                     max_energy_gain=np.zeros(P))


@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(st.data())
def test_the_merged_verdict_is_the_brute_force_merge(data):
    """Chunks of a sequence over random subsets of P samples: a sample is unstable at the
    first chunk that flags it, at the offset + the chunk's step, maxima are maxima and capped
    steps add up (a flagged sample leaves, as rollout_until_rest drops it)."""
    P = data.draw(st.integers(1, 5))
    merged = _Merged(P)
    offset = np.zeros(P, dtype=np.int64)
    want_step = np.full(P, -1)
    want_max = np.zeros((3, P))
    want_capped = np.zeros(P, dtype=np.int64)
    for _ in range(data.draw(st.integers(1, 4))):
        rows = np.array(sorted(data.draw(st.sets(st.integers(0, P - 1), min_size=1))))
        rows = rows[want_step[rows] < 0]
        if not len(rows):
            continue
        n = data.draw(st.integers(1, 20))
        flags = data.draw(st.lists(st.booleans(), min_size=len(rows), max_size=len(rows)))
        steps = [data.draw(st.integers(0, n - 1)) if f else -1 for f in flags]
        maxima = data.draw(st.lists(st.lists(st.floats(0, 10), min_size=len(rows),
                                             max_size=len(rows)), min_size=3, max_size=3))
        capped = data.draw(st.lists(st.integers(0, n), min_size=len(rows), max_size=len(rows)))
        merged.add(rows, _verdict(flags, steps, maxima, capped), offset[rows])
        for j, i in enumerate(rows):
            if flags[j]:
                want_step[i] = offset[i] + steps[j]
            want_max[:, i] = np.maximum(want_max[:, i], [m[j] for m in maxima])
            want_capped[i] += capped[j]
        offset[rows] += n
    v = merged.verdict()
    assert np.array_equal(v.unstable, want_step >= 0)
    assert np.array_equal(v.step, want_step)
    assert np.array_equal(np.stack([v.max_speed, v.max_penetration, v.max_strain]), want_max)
    assert np.array_equal(v.capped_steps, want_capped)
    assert all((r != "") == (s >= 0) for r, s in zip(v.reason, want_step, strict=True))


def test_bad_rest_settings_are_named(cloth, service):
    with pytest.raises(ValueError, match="check_every"):
        RestTest(check_every=0.0)
    with pytest.raises(ValueError, match="speed"):
        RestTest(speed=-1.0)
    with pytest.raises(TypeError, match="rest must be a RestTest"):
        PickPlaceTask(cloth, cloth.positions(cloth.initial_state), rollout=service, rest=0.01)
    with pytest.raises(TypeError, match="rest must be a RestTest"):
        rollout_until_rest(service, cloth.picker, cloth.velocity_dofs, cloth.initial_state,
                           [[0]], [[[0.0, 0.0, 0.05]]], rest=0.01)
