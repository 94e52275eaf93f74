"""Every public dopt function that takes arrays, indices or names raises ValueError / TypeError
naming the argument, not a deep IndexError, numpy broadcasting error or ctypes error, and never
returns garbage; settings are checked against the sizes they imply before anything is
allocated."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco's first import (dopt.render)

from types import SimpleNamespace  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import torch  # noqa: E402

from dopt import render  # noqa: E402
from dopt.costs import EEDistanceTerm, QuadraticCost  # noqa: E402
from dopt.mpc import MPC, MPCConfig, Plan  # noqa: E402
from dopt.rollout import RolloutConfig, RolloutService  # noqa: E402
from dopt.scene import Scene  # noqa: E402
from dopt.state import StateLayout, check_states, get_state, set_state  # noqa: E402
from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth  # noqa: E402
from dopt.tasks.pick.picker import PickerConfig  # noqa: E402
from dopt.tasks.pick.replay import replay  # noqa: E402
from dopt.tasks.pick.rope_scene import RopeSceneConfig, make_rope  # noqa: E402
from dopt.tasks.pick.scene import PickPlaceTask  # noqa: E402
from tests.dopt.models import MIXED_JOINTS, moving_state  # noqa: E402

OTHER = """<mujoco><worldbody><body><freejoint/><geom size=".1"/></body></worldbody></mujoco>"""


# ============================================================================ bad arguments
@pytest.fixture(scope="module")
def c():
    """Everything the argument probes call: the mixed-joint scene and a service on it, a
    small rope with its pick-and-place task, a cost, an MPC, a camera, images."""
    sc = Scene.from_xml(MIXED_JOINTS)
    m = sc.model
    x = moving_state(sc)
    nv, nu, ns = m.nv, m.nu, sc.nstate
    svc = RolloutService(sc, RolloutConfig(threads=1))
    T = 3
    traj = svc.trajectory(x, np.zeros((T, nu)))
    other = mujoco.MjModel.from_xml_string(OTHER)
    rope = make_rope(RopeSceneConfig(n=6, length=0.1))
    N = rope.n_particles
    task = PickPlaceTask(rope, rope.positions(rope.initial_state),
                         rollout=RolloutService(rope.scene, RolloutConfig(threads=1)))
    cost = QuadraticCost(sc, x[sc.layout["qpos"]], np.ones(2 * nv), np.ones(2 * nv), np.ones(nu))

    class Fixed:
        def optimise(self, state, plan):
            return plan

    class Broken:
        def optimise(self, state, plan):
            return Plan(np.full_like(plan.controls, np.nan))

    cam = render.fit_camera(np.zeros((2, 3)))
    return SimpleNamespace(
        sc=sc, m=m, d=mujoco.MjData(m), x=x, nv=nv, nu=nu, ns=ns, svc=svc, T=T, traj=traj,
        other=other, other_d=mujoco.MjData(other), rope=rope, N=N, task=task, cost=cost,
        mpc=MPC(sc, Fixed(), MPCConfig(timeout=3, synchronous=True), np.random.default_rng(0)),
        broken=MPC(sc, Broken(), MPCConfig(timeout=3, synchronous=True),
                   np.random.default_rng(0)),
        U=np.zeros((2, T, nu)), K=np.zeros((T, nu, 2)), cam=cam,
        img=np.zeros((8, 8, 3), np.uint8), pts=np.zeros((2, 3)),
        fk=lambda q: torch.zeros(q.shape[0], 3))


def _nan(shape):
    return np.full(shape, np.nan)


def _term(c, **kw):
    args = dict(fk=c.fk, arm_dofs=[0, 1], target_dofs=[5, 6], target_map=np.eye(3)[:, :2],
                offset=np.zeros(3))
    args.update(kw)
    return EEDistanceTerm(c.sc, **args)


def _seg(c, kw):
    return render.draw_segments(c.img, **kw)


V, T_ = ValueError, TypeError
CASES = [
    # ---------------------------------------------------------------- RolloutService.rollout
    ("rollout x0 NaN", lambda c: c.svc.rollout(_nan(c.ns), c.U), V,
     "initial_states contains NaN"),
    ("rollout x0 short", lambda c: c.svc.rollout(c.x[:-1], c.U), V,
     "initial_states must have shape"),
    ("rollout x0 3-D", lambda c: c.svc.rollout(c.x[None, None], c.U), V,
     "initial_states must have shape"),
    ("rollout x0 bool", lambda c: c.svc.rollout(c.x > 0, c.U), T_,
     "initial_states must be a float array"),
    ("rollout x0 str", lambda c: c.svc.rollout("x0", c.U), T_, "initial_states"),
    ("rollout x0 ragged", lambda c: c.svc.rollout([c.x, c.x[:3]], c.U), V, "initial_states"),
    ("rollout x0 None", lambda c: c.svc.rollout(None, c.U), T_, "initial_states"),
    ("rollout U inf", lambda c: c.svc.rollout(c.x, np.full((2, 3, c.nu), np.inf)), V,
     "controls contains NaN/inf"),
    ("rollout U wrong nu", lambda c: c.svc.rollout(c.x, c.U[..., :-1]), V,
     "controls must have shape"),
    ("rollout U 4-D", lambda c: c.svc.rollout(c.x, c.U[None]), V, "controls must have shape"),
    ("rollout U 1-D", lambda c: c.svc.rollout(c.x, c.U[0, 0]), V, "controls must have shape"),
    ("rollout U T=0", lambda c: c.svc.rollout(c.x, c.U[:, :0]), V, "controls must have shape"),
    ("rollout U complex", lambda c: c.svc.rollout(c.x, c.U + 0j), T_,
     "controls must be a float array"),
    ("rollout U ragged", lambda c: c.svc.rollout(c.x, [[[0, 0, 0]], [[0, 0]]]), V, "controls"),
    ("rollout P mismatch", lambda c: c.svc.rollout(np.stack([c.x] * 3), c.U), V,
     "initial_states has 3 rollouts but controls has 2"),
    ("rollout record unknown", lambda c: c.svc.rollout(c.x, c.U, record=("nope",)), V,
     "record"),
    ("rollout record float", lambda c: c.svc.rollout(c.x, c.U, record=(1.5,)), T_, "record"),
    ("rollout record str", lambda c: c.svc.rollout(c.x, c.U, record="qpos"), T_, "record"),
    ("rollout control_spec float", lambda c: c.svc.rollout(c.x, c.U, control_spec=1.5), T_,
     "control_spec"),
    ("rollout control_spec bool", lambda c: c.svc.rollout(c.x, c.U, control_spec=True), T_,
     "control_spec"),
    ("rollout control_spec qpos", lambda c: c.svc.rollout(c.x, c.U, control_spec=2), V,
     "control_spec"),
    # ---------------------------------------------------------------------------- trajectory
    ("trajectory x0 batch", lambda c: c.svc.trajectory(np.stack([c.x] * 2), c.U[0]), V,
     "initial_state must have shape"),
    ("trajectory U 3-D", lambda c: c.svc.trajectory(c.x, c.U), V,
     r"controls must have shape \(T"),
    ("trajectory U NaN", lambda c: c.svc.trajectory(c.x, _nan((3, c.nu))), V,
     "controls contains NaN"),
    ("trajectory U wrong nu", lambda c: c.svc.trajectory(c.x, np.zeros((3, 2))), V,
     "controls must have shape"),
    # ---------------------------------------------------------------------- rollout_feedback
    ("feedback U 2-D", lambda c: c.svc.rollout_feedback(c.x, c.U[0], c.traj.states[:-1], c.K,
                                                        [0]), V, r"controls must have shape"),
    ("feedback ref wrong T", lambda c: c.svc.rollout_feedback(c.x, c.U, c.traj.states, c.K,
                                                              [0]), V, "ref_states"),
    ("feedback ref NaN", lambda c: c.svc.rollout_feedback(c.x, c.U, _nan((3, c.ns)), c.K, [0]),
     V, "ref_states contains NaN"),
    ("feedback gains shape", lambda c: c.svc.rollout_feedback(c.x, c.U, c.traj.states[:-1],
                                                              c.K[:, :, :1], [0]), V, "gains"),
    ("feedback gains NaN", lambda c: c.svc.rollout_feedback(c.x, c.U, c.traj.states[:-1],
                                                            _nan(c.K.shape), [0]), V,
     "gains contains NaN"),
    ("feedback dofs -1", lambda c: c.svc.rollout_feedback(c.x, c.U, c.traj.states[:-1], c.K,
                                                          [-1]), V, r"dofs.*\[-1\]"),
    ("feedback dofs name", lambda c: c.svc.rollout_feedback(c.x, c.U, c.traj.states[:-1], c.K,
                                                            "nope"), V, "unknown DoF group"),
    ("feedback x0 inf", lambda c: c.svc.rollout_feedback(np.full(c.ns, np.inf), c.U,
                                                         c.traj.states[:-1], c.K, [0]), V,
     "initial_state contains NaN"),
    # --------------------------------------------------------------------------- derivatives
    ("derivatives states 1-D", lambda c: c.svc.derivatives(c.x), V, "states must have shape"),
    ("derivatives dofs nv", lambda c: c.svc.derivatives(c.traj.states, [c.nv]), V,
     r"dofs.*\[17\]"),
    ("derivatives dofs float", lambda c: c.svc.derivatives(c.traj.states, [1.0]), T_, "dofs"),
    ("derivatives fd dict", lambda c: c.svc.derivatives(c.traj.states, None, {"eps": 1e-3}),
     T_, "fd must be a dopt.FDConfig"),
    ("service config dict", lambda c: RolloutService(c.sc, {"threads": 1}), T_,
     "config must be a dopt.RolloutConfig"),
    # --------------------------------------------------------------------------------- state
    ("get_state model None", lambda c: get_state(None, c.d), T_, "model must be a"),
    ("get_state data None", lambda c: get_state(c.m, None), T_, "data must be a"),
    ("get_state spec huge", lambda c: get_state(c.m, c.d, 1 << 20), V, "spec"),
    ("get_state spec float", lambda c: get_state(c.m, c.d, 2.5), T_, "spec"),
    ("get_state data of other model", lambda c: get_state(c.m, c.other_d), V, "data"),
    ("set_state data of other model", lambda c: set_state(c.m, c.other_d, c.x), V, "data"),
    ("set_state short", lambda c: set_state(c.m, c.d, c.x[:-1]), V, "state must have shape"),
    ("set_state NaN", lambda c: set_state(c.m, c.d, _nan(c.ns)), V, "state contains NaN"),
    ("check_states ragged", lambda c: check_states(c.m, [c.x, c.x[:2]]), V, "state"),
    ("check_states spec -1", lambda c: check_states(c.m, c.x, -1), V, "spec"),
    ("check_states object", lambda c: check_states(c.m, np.array([None] * c.ns), name="x0"),
     T_, "x0 must be a float array"),
    ("StateLayout spec", lambda c: StateLayout.of(c.m, -1), V, "spec"),
    # --------------------------------------------------------------------------------- Scene
    ("dofs(1)", lambda c: c.sc.dofs(1), T_, "DoF group names must be str"),
    ("dofs unknown", lambda c: c.sc.dofs("nope"), V, "unknown DoF group 'nope'"),
    ("Scene group -1", lambda c: Scene(c.m, {"g": [-1]}), V, r"g: index out of range"),
    ("Scene group float", lambda c: Scene(c.m, {"g": [0.5]}), T_, "g must be integer"),
    ("Scene group name int", lambda c: Scene(c.m, {3: [0]}), T_, "group names must be str"),
    ("Scene from_xml int", lambda c: Scene.from_xml(3), T_, "xml must be an MJCF string"),
    ("state_of None", lambda c: c.sc.state_of(None), T_, "data must be a"),
    ("state_of other model", lambda c: c.sc.state_of(c.other_d), V, "data"),
    # --------------------------------------------------------------------------------- costs
    ("cost q_ref shape", lambda c: QuadraticCost(c.sc, np.zeros(3), c.cost.w, c.cost.w_f,
                                                 c.cost.r), V, "q_ref must have shape"),
    ("cost q_ref str", lambda c: QuadraticCost(c.sc, ["a"] * c.m.nq, c.cost.w, c.cost.w_f,
                                               c.cost.r), T_, "q_ref"),
    ("cost w negative", lambda c: QuadraticCost(c.sc, c.cost.q_ref, -np.ones(2 * c.nv),
                                                c.cost.w_f, c.cost.r), V, "w must be non-neg"),
    ("cost w_f NaN", lambda c: QuadraticCost(c.sc, c.cost.q_ref, c.cost.w, _nan(2 * c.nv),
                                             c.cost.r), V, "w_f contains NaN"),
    ("cost r bool", lambda c: QuadraticCost(c.sc, c.cost.q_ref, c.cost.w, c.cost.w_f,
                                            np.ones(c.nu, bool)), T_, "r must be a float"),
    ("cost v_ref shape", lambda c: QuadraticCost(c.sc, c.cost.q_ref, c.cost.w, c.cost.w_f,
                                                 c.cost.r, v_ref=np.zeros(3)), V, "v_ref"),
    ("cost terms", lambda c: QuadraticCost(c.sc, c.cost.q_ref, c.cost.w, c.cost.w_f, c.cost.r,
                                           terms=[1]), T_, "terms"),
    ("cost total states ns", lambda c: c.cost.total(c.traj.states[:, :-1], c.U[0]), V,
     "states must have shape"),
    ("cost total controls T", lambda c: c.cost.total(c.traj.states, c.U[0, :2]), V, "controls"),
    ("cost total states NaN", lambda c: c.cost.total(_nan(c.traj.states.shape), c.U[0]), V,
     "states contains NaN"),
    ("cost total controls nu", lambda c: c.cost.total(c.traj.states, c.U[0, :, :2]), V,
     "controls"),
    ("cost errors ns", lambda c: c.cost.errors(c.x[:-1]), V, "states must have shape"),
    ("cost derivatives dofs", lambda c: c.cost.derivatives(c.traj.states, c.U[0], [-1]), V,
     r"dofs.*\[-1\]"),
    ("cost derivatives states 3-D", lambda c: c.cost.derivatives(c.traj.states[None], c.U[0],
                                                                 [0]), V, "states"),
    ("cost derivatives controls nu", lambda c: c.cost.derivatives(c.traj.states,
                                                                  c.U[0, :, :1], [0]), V,
     "controls"),
    ("term arm_dofs -1", lambda c: _term(c, arm_dofs=[-1, 1]), V, r"arm_dofs.*\[-1\]"),
    ("term arm_dofs float", lambda c: _term(c, arm_dofs=[0.5, 1]), T_, "arm_dofs"),
    ("term rotational", lambda c: _term(c, target_dofs=[8, 9]), V, "rotational"),
    ("term target_map", lambda c: _term(c, target_map=np.zeros(4)), V, "target_map"),
    ("term axes", lambda c: _term(c, axes=(0, 3)), V, "axes"),
    ("term weight NaN", lambda c: _term(c, weight=np.nan), V, "weight"),
    ("term offset", lambda c: _term(c, offset=np.zeros(2)), V, "offset"),
    ("term fk", lambda c: _term(c, fk=None), T_, "fk"),
    # ----------------------------------------------------------------------------------- mpc
    ("MPC config dict", lambda c: MPC(c.sc, c.mpc.optimiser, {"timeout": 3},
                                      np.random.default_rng(0)), T_, "config"),
    ("MPC optimiser", lambda c: MPC(c.sc, object(), c.mpc.config, np.random.default_rng(0)),
     T_, "optimiser"),
    ("MPC scene", lambda c: MPC(c.m, c.mpc.optimiser, c.mpc.config, np.random.default_rng(0)),
     T_, "scene"),
    ("MPC rng", lambda c: MPC(c.sc, c.mpc.optimiser, c.mpc.config, 0), T_, "rng"),
    ("MPC.run x0 NaN", lambda c: c.mpc.run(_nan(c.ns), Plan(c.U[0])), V,
     "initial_state contains NaN"),
    ("MPC.run plan array", lambda c: c.mpc.run(c.x, c.U[0]), T_, "plan must be a"),
    ("MPC.run controls NaN", lambda c: c.mpc.run(c.x, Plan(_nan((3, c.nu)))), V,
     "plan.controls contains NaN"),
    ("MPC.run controls nu", lambda c: c.mpc.run(c.x, Plan(np.zeros((3, 2)))), V,
     "plan.controls must have shape"),
    ("MPC.run controls T=0", lambda c: c.mpc.run(c.x, Plan(np.zeros((0, c.nu)))), V,
     "plan.controls"),
    ("MPC.run controls str", lambda c: c.mpc.run(c.x, Plan(np.full((3, c.nu), "a"))), T_,
     "plan.controls"),
    ("MPC.run plan.states", lambda c: c.mpc.run(c.x, Plan(c.U[0], states=c.traj.states[:2])),
     V, "plan.states"),
    ("MPC.run plan.K", lambda c: c.mpc.run(c.x, Plan(c.U[0], K=c.K[:, :, :1], dofs=[0])), V,
     "plan.K"),
    ("MPC.run plan.dofs", lambda c: c.mpc.run(c.x, Plan(c.U[0], K=c.K, dofs=[-1])), V,
     "plan.dofs"),
    ("MPC optimiser returns NaN", lambda c: c.broken.run(c.x, Plan(c.U[0])), V,
     "plan.controls contains NaN"),
    ("Plan.shifted float", lambda c: Plan(c.U[0]).shifted(1.5), T_, "steps"),
    # ---------------------------------------------------------------------------- pick tasks
    ("with_positions state short", lambda c: c.rope.with_positions(
        c.rope.initial_state[:-1], np.zeros((c.N, 3))), V, "state must have shape"),
    ("with_positions shape", lambda c: c.rope.with_positions(c.rope.initial_state,
                                                             np.zeros((c.N, 2))), V,
     "positions must have shape"),
    ("with_positions NaN", lambda c: c.rope.with_positions(c.rope.initial_state,
                                                           _nan((c.N, 3))), V,
     "positions contains NaN"),
    ("with_positions bool", lambda c: c.rope.with_positions(c.rope.initial_state,
                                                            np.zeros((c.N, 3), bool)), T_,
     "positions"),
    ("scene positions ns", lambda c: c.rope.positions(c.rope.initial_state[:-1]), V,
     "states must have shape"),
    ("settle negative", lambda c: c.rope.settle(c.rope.initial_state, -1.0), V, "seconds"),
    ("settle NaN", lambda c: c.rope.settle(c.rope.initial_state, np.nan), V, "seconds"),
    ("task goal shape", lambda c: PickPlaceTask(c.rope, np.zeros((c.N, 2)),
                                                rollout=c.task.service), V, "goal"),
    ("task start NaN", lambda c: PickPlaceTask(c.rope, c.task.goal, _nan(c.rope.nstate),
                                               rollout=c.task.service), V, "start_state"),
    ("task scene", lambda c: PickPlaceTask(c.rope.scene, c.task.goal), T_, "scene"),
    ("task rollout", lambda c: PickPlaceTask(c.rope, c.task.goal, rollout="svc"), T_,
     "rollout"),
    ("task blowup_out", lambda c: PickPlaceTask(c.rope, c.task.goal, blowup_out=3), T_,
     "blowup_out"),
    ("task blowup_label", lambda c: PickPlaceTask(c.rope, c.task.goal, blowup_label=None), T_,
     "blowup_label"),
    ("evaluate particle N", lambda c: c.task.evaluate([[c.N]], np.zeros((1, 1, 3))), V,
     f"particle index {6}"),
    ("evaluate particle -2", lambda c: c.task.evaluate([[-2]], np.zeros((1, 1, 3))), V,
     "particle index -2"),
    ("evaluate particle 1.5", lambda c: c.task.evaluate([[1.5]], np.zeros((1, 1, 3))), V,
     "particle indices must be integers"),
    ("evaluate particle bool", lambda c: c.task.evaluate([[True]], np.zeros((1, 1, 3))), T_,
     "particles must be integer"),
    ("evaluate particle str", lambda c: c.task.evaluate([["a"]], np.zeros((1, 1, 3))), T_,
     "particles must be integer"),
    ("evaluate particle NaN", lambda c: c.task.evaluate([[np.nan]], np.zeros((1, 1, 3))), V,
     "particle indices must be integers"),
    ("evaluate disp (P, H, 2)", lambda c: c.task.evaluate([[0]], np.zeros((1, 1, 2))), V,
     "displacements"),
    ("evaluate disp H mismatch", lambda c: c.task.evaluate([[0, 1]], np.zeros((1, 1, 3))), V,
     "displacements"),
    ("evaluate disp NaN", lambda c: c.task.evaluate([[0]], _nan((1, 1, 3))), V,
     "displacement of sequence 0, action 0 is not finite"),
    ("evaluate disp str", lambda c: c.task.evaluate([[0]], [[["a", "b", "c"]]]), T_,
     "displacements must be a float"),
    ("evaluate H=0", lambda c: c.task.evaluate(np.zeros((1, 0), int), np.zeros((1, 0, 3))), V,
     "particles.*at least one"),
    ("evaluate P=0", lambda c: c.task.evaluate(np.zeros((0, 1), int), np.zeros((0, 1, 3))), V,
     "particles.*at least one"),
    ("evaluate disp beyond bound", lambda c: c.task.evaluate([[0]], [[[1.0, 0, 0]]]), V,
     "beyond the bound"),
    ("task step particle float", lambda c: c.task.step(c.task.start_state, 1.5, [0, 0, 0]), T_,
     "particle"),
    ("task step displacement", lambda c: c.task.step(c.task.start_state, 0, [0, 0]), V,
     "displacement"),
    ("task rollout start NaN", lambda c: c.task.rollout([[0]], np.zeros((1, 1, 3)),
                                                        _nan(c.rope.nstate)), V,
     "start contains NaN"),
    ("encode particle N", lambda c: c.rope.picker.encode([[c.N]], np.zeros((1, 1, 3))), V,
     "particle index"),
    ("decode shape", lambda c: c.rope.picker.decode(np.zeros((1, 5, 3))), V, "controls"),
    ("decode str", lambda c: c.rope.picker.decode(np.full((1, 1, 1), "a")), T_, "controls"),
    ("make_rope pickable N", lambda c: make_rope(RopeSceneConfig(n=6), pickable=[6]), V,
     r"pickable.*\[6\]"),
    ("make_rope pickable -1", lambda c: make_rope(RopeSceneConfig(n=6), pickable=[-1]), V,
     r"pickable.*\[-1\]"),
    ("make_cloth pickable float", lambda c: make_cloth(ClothSceneConfig(n=3), pickable=[1.5]),
     T_, "pickable"),
    ("make_rope config dict", lambda c: make_rope({"n": 6}), T_, "config"),
    ("make_rope picker dict", lambda c: make_rope(RopeSceneConfig(n=6), {"bound": 1}), T_,
     "picker"),
    ("make_rope positions shape", lambda c: make_rope(RopeSceneConfig(n=6),
                                                      positions=np.zeros((5, 3))), V,
     "positions"),
    # -------------------------------------------------------------------------------- render
    ("fit_camera points (N, 2)", lambda c: render.fit_camera(np.zeros((3, 2))), V, "points"),
    ("fit_camera points NaN", lambda c: render.fit_camera(_nan((2, 3))), V, "points"),
    ("fit_camera fill", lambda c: render.fit_camera(c.pts, fill=0.0), V, "fill"),
    ("fit_camera fovy", lambda c: render.fit_camera(c.pts, fovy=np.nan), V, "fovy"),
    ("fit_camera azimuth", lambda c: render.fit_camera(c.pts, "x"), T_, "azimuth"),
    ("project points (N, 2)", lambda c: render.project(np.zeros((3, 2)), c.cam, 8, 8), V,
     "points"),
    ("project camera", lambda c: render.project(c.pts, None, 8, 8), T_, "camera"),
    ("project width 0", lambda c: render.project(c.pts, c.cam, 0, 8), V, "width"),
    ("project width float", lambda c: render.project(c.pts, c.cam, 8.5, 8), T_, "width"),
    ("render_states ns", lambda c: render.render_states(c.m, c.traj.states[:, :-1],
                                                        c.sc.layout.spec, c.cam, 8, 8), V,
     "states must have shape"),
    ("render_states NaN", lambda c: render.render_states(c.m, _nan((1, c.ns)),
                                                         c.sc.layout.spec, c.cam, 8, 8), V,
     "states contains NaN"),
    ("render_states width", lambda c: render.render_states(c.m, c.traj.states,
                                                           c.sc.layout.spec, c.cam, 0, 8), V,
     "width"),
    ("render_states cameras", lambda c: render.render_states(c.m, c.traj.states,
                                                             c.sc.layout.spec, "top", 8, 8),
     T_, "cameras"),
    ("render_states spec", lambda c: render.render_states(c.m, c.traj.states, 1.5, c.cam, 8, 8),
     T_, "spec"),
    ("render_states hide_geoms", lambda c: render.render_states(
        c.m, c.traj.states, c.sc.layout.spec, c.cam, 8, 8, hide_geoms=[99]), V, "hide_geoms"),
    ("render_states geom_alpha", lambda c: render.render_states(
        c.m, c.traj.states, c.sc.layout.spec, c.cam, 8, 8, geom_alpha={0: 2.0}), V,
     "geom_alpha"),
    ("render state 2-D", lambda c: render.render(c.m, c.traj.states, c.sc.layout.spec, c.cam,
                                                 8, 8), V, "state must have shape"),
    ("object_mask shape", lambda c: render.object_mask(np.zeros((4, 4, 3))), V,
     "segmentation"),
    ("mask_outline 3-D", lambda c: render.mask_outline(np.zeros((2, 4, 4))), V, "mask"),
    ("mask_outline width", lambda c: render.mask_outline(np.zeros((4, 4)), width=0), V,
     "width"),
    ("draw_markers image 2-D", lambda c: render.draw_markers(np.zeros((4, 4)), c.pts[:, :2]), V,
     "image"),
    ("draw_markers pixels (M, 3)", lambda c: render.draw_markers(c.img, np.zeros((2, 3))), V,
     "pixels"),
    ("draw_markers radius", lambda c: render.draw_markers(c.img, c.pts[:, :2], radius=np.nan),
     V, "radius"),
    ("draw_markers colour", lambda c: render.draw_markers(c.img, c.pts[:, :2], colour=(1, 2)),
     V, "colour"),
    ("draw_markers style", lambda c: render.draw_markers(c.img, c.pts[:, :2], style="star"), V,
     "style"),
    ("draw_segments lengths", lambda c: _seg(c, dict(start=np.zeros((2, 2)),
                                                     end=np.zeros((3, 2)))), V, "end"),
    ("draw_segments (M, 3)", lambda c: _seg(c, dict(start=np.zeros((2, 3)),
                                                    end=np.zeros((2, 3)))), V, "start"),
    ("replay action keys", lambda c: replay(c.rope, c.rope.initial_state,
                                                   [{"particles": [0]}]), V, "actions"),
    ("replay max_frames", lambda c: replay(c.rope, c.rope.initial_state, [],
                                                  max_frames=1.5), T_, "max_frames"),
    ("replay start_state", lambda c: replay(c.rope, c.rope.initial_state[:-1], []), V,
     "start_state"),
]


@pytest.mark.parametrize("call, exc, match", [pytest.param(*case[1:], id=case[0])
                                              for case in CASES])
def test_bad_argument_is_named(c, call, exc, match):
    with pytest.raises(exc, match=match):
        call(c)


INDEX_PROBES = [([-1], ValueError, r"dofs: index out of range \[0, 17\): \[-1\]"),
                ([17], ValueError, r"dofs: index out of range \[0, 17\): \[17\]"),
                ([1.5], TypeError, "dofs must be integers"),
                ([2.0], TypeError, "dofs must be integers"),
                ([np.nan], TypeError, "dofs must be integers"),
                ([True], TypeError, "dofs must be integers"),
                (True, TypeError, "dofs must be integers"),
                (None, TypeError, "dofs must be"),
                ([[0, 1], [2]], ValueError, "dofs is not a rectangular array"),
                ([], ValueError, "dofs is empty")]


@pytest.mark.parametrize("method", ["as_dofs", "qpos_indices", "tangent_indices",
                                    "linear_qpos_indices"])
@pytest.mark.parametrize("dofs, exc, match", INDEX_PROBES,
                         ids=[repr(p[0]) for p in INDEX_PROBES])
def test_scene_dof_indices(c, method, dofs, exc, match):
    with pytest.raises(exc, match=match):
        getattr(c.sc, method)(dofs)


def test_scene_dof_indices_accept_numpy_ints_and_names(c):
    assert c.sc.linear_qpos_indices(np.array([1, 0], np.int32)).tolist() == [1, 0]
    assert c.sc.linear_qpos_indices("joint:slide").tolist() == [0]
    assert c.sc.as_dofs(np.array([3, 0], dtype=object)).tolist() == [0, 3]


# ------------------------------------------------- sizes a setting implies, before allocating
def test_picker_sizes_are_checked_against_the_workspace_and_the_steps_of_an_action():
    """--bound 1e9 and --picker-speed 1e-9 once ended in "MemoryError: Unable to allocate
    2.52 TiB" (one action's steps); a rope of more particles than its length holds in a
    MuJoCo XML error."""
    from dopt.tasks.pick.constraints import ActionConstraint
    from dopt.tasks.pick.picker import MAX_STEPS_PER_ACTION

    with pytest.raises(ValueError, match=r"PickerConfig.bound 1e\+09 m is beyond the "
                                         r"workspace: the picker cannot move farther than "
                                         r"0.6 m along x"):
        PickerConfig(bound=(1e9,) * 3, workspace=ActionConstraint.table(0.3))
    with pytest.raises(ValueError, match=rf"1.73e\+10 steps of 0.01 s .* more than "
                                         rf"{MAX_STEPS_PER_ACTION}; raise the speed"):
        PickerConfig(speed=1e-9).steps(0.01)
    assert PickerConfig().steps(0.01) == (6, 1, 35, 25)           # the picker's own count
    with pytest.raises(ValueError, match="RopeSceneConfig.n 52 puts the particles 0.0098 m "
                                         "apart, closer than their diameter 0.01 m: a 0.5 m "
                                         "rope holds at most 51"):
        RopeSceneConfig(n=52)
    RopeSceneConfig(n=51)
