"""A Franka Panda with a parallel gripper that executes pick-and-place plans on the cloth or
rope open-loop through inverse kinematics, as the key-particle paper's Sec. IV-D did on
hardware; the floating picker is what the plans were made with.

The arm is ``dopt.tasks.panda``'s (7 torque-driven joints, gravity compensated, joint
damping 100 / 10 N m s/rad) with the pusher replaced by a hand: two fingers on slide joints
(position actuators, 0-4 cm each) and the site ``PINCH`` between the fingertips, 0.1034 m from
the flange (Franka's hand). It stands on the floor at ``base``, facing +x, beside the object.

One action (i, d) becomes a pinch-site path (``PandaExecutor``): above particle i
(``approach`` m), down to it (both following the particle, which may still be settling from
the previous release), close the fingers and grasp, carry it by d along the picker's smooth
profile in the picker's move time for d (``Picker.moves``), release and open, lift, and wait
the picker's settle time. The pinch target keeps the picker's limits: not below one particle
radius (the picker's floor stop) and inside its workspace box (C(a_t)). Every step,
damped-least-squares IK of the path point (hand pointing down, warm started) gives the joint
reference, and computed-torque control (the arm's mass matrix times the reference
acceleration plus PD, the joints' own damping cancelled) gives the torques, clipped to the
datasheet's. The grasp itself is a connect equality between the hand and the particle,
switched on when the pinch site is within ``grasp_tolerance`` of it: the same hold the
picker has, so that a comparison with the picker measures the arm's motion, not a grasp
model. The fingers close for the picture and do not collide with anything.

The replay is judged by the scene's stability bounds and MuJoCo's warnings after every step;
``execute(..., blowup_out=OUT)`` writes a blow-up capture of its first failure (the last
``dopt.blowup.KEEP`` states of the combined model, kept in a ring buffer) to
``OUT/blowups/<blowup_label>``, which ``dopt-view`` opens at the failing step.

Shapes: N particles, H actions, ns state row of the combined model.
"""

from __future__ import annotations

import collections
import logging
import os
from dataclasses import dataclass, field

import mujoco
import numpy as np

from dopt.blowup import KEEP, capture_dir, save_blowup
from dopt.scene import Scene
from dopt.stability import Monitor, Stability
from dopt.tasks.panda import (
    JOINT_NAMES,
    Q_LOWER,
    Q_UPPER,
    TAU_MAX,
    panda_spec,
)
from dopt.tasks.pick.picker import fix_grasp_anchors, grasp_equalities, smooth_profile
from dopt.tasks.pick.scene import DeformableScene
from dopt.validation import check_config, float_array

log = logging.getLogger(__name__)

#: the pinch site between the fingertips (Franka's TCP, 0.1034 m from the flange)
PINCH = "arm/panda_pinch"
HAND = "arm/panda_hand"
FINGERS = ("arm/panda_finger_left", "arm/panda_finger_right")
_TCP = 0.1034
#: what a snapshot holds: MuJoCo's integration state of the combined model
SNAPSHOT_SPEC = int(mujoco.mjtState.mjSTATE_INTEGRATION)
_DOWN = np.array([0.0, 0.0, -1.0])
_READY = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, np.pi / 4])


def hand_spec() -> mujoco.MjSpec:
    """The Panda spec with a parallel-gripper hand instead of the pusher."""
    spec = panda_spec()
    spec.delete(spec.body("panda_pusher"))          # with its tip site
    link7 = spec.body("panda_link7")
    hand = link7.add_body(name="panda_hand", pos=[0, 0, 0.107], gravcomp=1)
    hand.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.02, 0.09, 0.03], pos=[0, 0, 0.03],
                  mass=0.6, contype=0, conaffinity=0, rgba=[0.9, 0.9, 0.9, 1])
    for side, sign in (("left", 1.0), ("right", -1.0)):
        finger = hand.add_body(name=f"panda_finger_{side}", pos=[0, 0, 0.0584], gravcomp=1)
        finger.add_joint(name=f"panda_finger_joint_{side}", type=mujoco.mjtJoint.mjJNT_SLIDE,
                         axis=[0, sign, 0], range=[0.0, 0.04], damping=10.0, armature=0.01)
        finger.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.008, 0.004, 0.024],
                        pos=[0, sign * 0.004, 0.022], mass=0.015, contype=0, conaffinity=0,
                        rgba=[0.25, 0.25, 0.25, 1])
        act = spec.add_actuator(name=f"panda_finger_{side}", target=f"panda_finger_joint_{side}",
                                trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_position(kp=200.0)
        act.ctrlrange = [0.0, 0.04]
        act.ctrllimited = 1
    hand.add_site(name="panda_pinch", pos=[0, 0, _TCP], size=[0.005, 0, 0])
    return spec


@dataclass(frozen=True)
class PandaConfig:
    """The arm beside the object and how it executes.

    Attributes:
        base: (3,) where the arm's base stands (m; the object is centred on the origin).
        approach: height above a particle the hand comes down from and lifts to (m).
        approach_time: seconds of each free move (to above the particle, down, up).
        grasp_steps: steps to close (and, after the release, to open) the fingers.
        grasp_tolerance: largest pinch-to-particle distance the grasp switches on at (m).
        kp, kd: joint PD gains of the computed-torque law (1/s^2, 1/s) for joints 1-4 and
            5-7 (400, 40: 20 rad/s, critically damped; 0.4 rad per step at dt 0.02).
        ik_iterations: damped-least-squares iterations per step (warm started).
    """

    base: tuple[float, float, float] = (-0.45, 0.0, 0.0)
    approach: float = 0.06
    approach_time: float = 0.6
    grasp_steps: int = 5
    grasp_tolerance: float = 0.01
    kp: tuple[float, float] = (400.0, 400.0)
    kd: tuple[float, float] = (40.0, 40.0)
    ik_iterations: int = 5

    def __post_init__(self):
        check_config(self, positive=("approach", "approach_time", "grasp_tolerance", "kp",
                                     "kd"),
                     minimum={"grasp_steps": 1, "ik_iterations": 1})


def panda_scene(scene: DeformableScene, config: PandaConfig = PandaConfig(),
                pickable=None) -> tuple[mujoco.MjModel, dict]:
    """The scene's object and floor with the arm added at ``config.base``: the combined model
    and the names it holds ({"grip": {particle: equality id}}). ``pickable``: particles the
    hand may grasp (default: every particle the scene's picker may)."""
    if not isinstance(scene, DeformableScene):
        raise TypeError(f"scene must be a DeformableScene, got {type(scene).__name__}")
    if not isinstance(config, PandaConfig):
        raise TypeError(f"config must be a PandaConfig, got {type(config).__name__}")
    if not scene.xml:
        raise ValueError("scene was built without its MJCF text (DeformableScene.xml)")
    spec = mujoco.MjSpec.from_string(scene.xml)
    frame = spec.worldbody.add_frame(pos=list(config.base))
    spec.attach(hand_spec(), prefix="arm/", frame=frame)
    particles = scene.picker.pickable if pickable is None else np.asarray(pickable, int)
    for i in particles:
        eq = spec.add_equality(name=f"grip{int(i)}", type=mujoco.mjtEq.mjEQ_CONNECT,
                               objtype=mujoco.mjtObj.mjOBJ_BODY, name1=HAND,
                               name2=f"{scene.flex}_{int(i)}", active=False)
        eq.data[:3] = [0.0, 0.0, _TCP]              # the anchor: the pinch point on the hand
        eq.solref = list(scene.picker.config.solref)   # the picker's own hold
    model = spec.compile()
    fix_grasp_anchors(model, "grip")
    return model, {"grip": grasp_equalities(model, "grip")}


@dataclass
class PandaExecution:
    """What the arm did: the final object positions (N, 3), the pinch-to-particle distance at
    each grasp attempt (m), the largest pinch tracking error of each carry (m), the actions
    skipped because the pinch could not reach the particle (indices into the plan), the
    combined model's
    states (``SNAPSHOT_SPEC``) at the start and after each grasp, carry and release (with
    ``snapshots``; for pictures), the number of steps, the stability verdict on the replay
    (``dopt.stability``, the scene's bounds, checked after every step; MuJoCo's warnings
    count as unstable, at the step they first appear) and the blow-up capture folders written
    (``execute``'s ``blowup_out``)."""

    positions: np.ndarray
    grasp_distance: list = field(default_factory=list)
    carry_error: list = field(default_factory=list)
    snapshots: list = field(default_factory=list)
    missed: list = field(default_factory=list)
    steps: int = 0
    stability: Stability | None = None
    blowups: list = field(default_factory=list)

    @property
    def unstable(self) -> bool:
        """Whether the replay broke a stability bound or made MuJoCo warn."""
        return bool(self.stability is not None and self.stability.unstable[0])


class PandaExecutor:
    """Executes plans of a ``DeformableScene``'s picker with the arm (module docstring).

    Args:
        scene: the rope or cloth scene the plan was made on (its picker's timing is reused).
        config: the arm's placement and gains.
        pickable: particles the hand may grasp (default: the picker's).
    """

    def __init__(self, scene: DeformableScene, config: PandaConfig = PandaConfig(),
                 pickable=None):
        self.scene, self.config = scene, config
        self.model, names = panda_scene(scene, config, pickable)
        self.grip = names["grip"]
        m = self.model
        self.data = mujoco.MjData(m)
        self.site = m.site(PINCH).id
        joints = [m.joint(f"arm/{n}") for n in JOINT_NAMES]
        self.qadr = np.array([j.qposadr[0] for j in joints])
        self.dadr = np.array([j.dofadr[0] for j in joints])
        self.motors = np.array([m.actuator(f"arm/panda_motor{i}").id for i in range(1, 8)])
        self.fingers = np.array([m.actuator(f).id for f in FINGERS])
        self.damping = m.dof_damping[self.dadr].copy()
        self.kp = np.where(np.arange(7) < 4, config.kp[0], config.kp[1])
        self.kd = np.where(np.arange(7) < 4, config.kd[0], config.kd[1])
        self.dt = float(m.opt.timestep)
        pk = scene.picker
        self.settle_steps = pk.settle_steps
        self._scratch = mujoco.MjData(m)               # kinematics of reference poses
        self._vert = {i: m.body(f"{scene.flex}_{i}").id for i in self.grip}
        combined = Scene(m)
        f = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_FLEX, scene.flex)
        vadr = int(m.flex_vertadr[f])
        self._vq = np.stack([combined.qpos_indices(f"vertex:{vadr + i}")
                             for i in range(scene.n_particles)])                       # (N, 3)
        bodies = m.flex_vertbodyid[vadr:vadr + scene.n_particles]
        self._origin = m.body_pos[bodies] - m.qpos0[self._vq]
        self._qref = self._qdref = None
        self._M = np.zeros((m.nv, m.nv))
        self.monitor = Monitor(m, scene.scene.stability)
        self._scan = None
        self._blowup, self._ring, self._blowups = None, None, []  # where to capture, the ring
        # the picker's limits, held by the pinch target: the floor stop at one particle radius
        # and the workspace box of C(a_t)
        box = scene.picker.config.workspace
        self._low = np.array([-np.inf, -np.inf, scene.radius])
        self._high = np.full(3, np.inf)
        if box is not None:
            self._low = np.maximum(self._low, box.low)
            self._high = np.array(box.high)

    # ------------------------------------------------------------------ the start
    def start(self, object_state: np.ndarray) -> None:
        """Put the object as in ``object_state`` (a state row of the scene) and the arm at
        its ready pose with the hand open; the stability verdict starts over."""
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        d.qpos[self._vq] = self.scene.positions(object_state) - self._origin
        d.qpos[self.qadr] = _READY
        d.ctrl[self.fingers] = 0.04
        mujoco.mj_forward(m, d)
        self._qref = d.qpos[self.qadr].copy()
        self._qdref = np.zeros(7)
        self._scan, self._t = self.monitor.start(1), 0
        self._ring = (None if self._blowup is None
                      else collections.deque([self.state()], maxlen=KEEP))

    # ------------------------------------------------------------------ motion
    def _ik(self, target: np.ndarray) -> np.ndarray:
        m, d = self.model, self.data
        q = self._qref.copy()
        scratch = self._scratch
        scratch.qpos[:] = d.qpos
        jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        for _ in range(self.config.ik_iterations):
            scratch.qpos[self.qadr] = q
            mujoco.mj_kinematics(m, scratch)
            mujoco.mj_comPos(m, scratch)
            axis = scratch.site_xmat[self.site].reshape(3, 3)[:, 2]
            err = np.concatenate([target - scratch.site_xpos[self.site], np.cross(axis, _DOWN)])
            mujoco.mj_jacSite(m, scratch, jp, jr, self.site)
            jac = np.vstack([jp, jr])[:, self.dadr]
            q = q + jac.T @ np.linalg.solve(jac @ jac.T + 1e-4 * np.eye(6), err)
            q = np.clip(q, Q_LOWER + 0.01, Q_UPPER - 0.01)
        return q

    def _step(self, target: np.ndarray) -> None:
        """One step toward the pinch ``target``: computed-torque control of the IK reference,
        tau = M (qdd_ref + kp e + kd de) + damping qd (the joints' own damping cancelled)."""
        m, d = self.model, self.data
        q_ref = self._ik(np.clip(target, self._low, self._high))
        qd_ref = (q_ref - self._qref) / self.dt
        qdd_ref = (qd_ref - self._qdref) / self.dt
        self._qref, self._qdref = q_ref, qd_ref
        q, qd = d.qpos[self.qadr], d.qvel[self.dadr]
        mujoco.mj_fullM(m, d, self._M)
        acc = qdd_ref + self.kp * (q_ref - q) + self.kd * (qd_ref - qd)
        tau = self._M[np.ix_(self.dadr, self.dadr)] @ acc + self.damping * qd
        d.ctrl[self.motors] = np.clip(tau, -TAU_MAX, TAU_MAX)
        mujoco.mj_step(m, d)
        if self._ring is not None:
            self._ring.append(self.state())
        if not self._scan.unstable[0]:
            self._judge(d)
        self._t += 1

    def _judge(self, d: mujoco.MjData) -> None:
        """The verdict on step ``_t``, not yet unstable: the bounds, then MuJoCo's warnings
        (which win at the same step); the capture of a failure (``_blowup``)."""
        self._scan.update(np.zeros(1, int), self._t,
                          {k: np.asarray(getattr(d, k))[None, None] for k in self.monitor.record})
        warned = [mujoco.mjtWarning(w).name for w in range(len(d.warning)) if d.warning[w].number]
        if warned:
            self._scan.flag(0, self._t, "MuJoCo warned: " + ", ".join(warned))
        if self._scan.unstable[0] and self._ring is not None:
            out, label = self._blowup
            try:
                self._blowups.append(str(save_blowup(
                    capture_dir(out, label), self.model, np.array(self._ring), self._t,
                    self._scan.reason[0], spec=SNAPSHOT_SPEC, label=label)))
            except OSError as e:
                log.error("the blow-up capture of the arm's step %d was not written: %s",
                          self._t, e)

    def pinch(self) -> np.ndarray:
        """(3,) the pinch site's position now (m)."""
        return self.data.site_xpos[self.site].copy()

    def _move(self, goal, steps: int, profile: np.ndarray | None = None,
              hold: bool = False) -> float:
        """Pinch from its reference to ``goal`` ((3,), or a function giving it at each step)
        in ``steps`` steps along ``profile`` (default a smooth 0 -> 1); ``hold``: at the goal
        throughout. Returns the largest tracking error (m)."""
        a = self._target_now()
        s = (np.ones(steps) if hold else smooth_profile(steps)[1:] if profile is None
             else profile)
        worst = 0.0
        for k in range(steps):
            g = goal() if callable(goal) else goal
            target = a + s[k] * (g - a)
            self._step(target)
            worst = max(worst, float(np.linalg.norm(self.pinch() - target)))
        return worst

    def _hold(self, steps: int) -> None:
        target = self._target_now()
        for _ in range(steps):
            self._step(target)

    def _target_now(self) -> np.ndarray:
        scratch = self._scratch
        scratch.qpos[:] = self.data.qpos
        scratch.qpos[self.qadr] = self._qref
        mujoco.mj_kinematics(self.model, scratch)
        return scratch.site_xpos[self.site].copy()

    def particle(self, i: int) -> np.ndarray:
        """(3,) particle i's position now (m)."""
        return self.data.xpos[self._vert[int(i)]].copy()

    # ------------------------------------------------------------------ actions
    def execute(self, object_state: np.ndarray, particles, displacements,
                snapshots: bool = False, blowup_out: str | os.PathLike | None = None,
                blowup_label: str = "panda") -> PandaExecution:
        """Run the plan ``particles`` (H,), ``displacements`` (H, 3) from ``object_state``.

        An action whose particle the pinch does not reach within ``grasp_tolerance`` (out of
        the arm's reach, or the arm blocked) is skipped and listed in ``missed``.
        ``blowup_out``: a run folder that receives a blow-up capture of the replay's first
        failure as ``blowups/<blowup_label>`` (module docstring); None: no capture.

        Raises:
            ValueError: a particle the hand cannot grasp, or a plan of bad shape.
        """
        idx = np.asarray(particles).reshape(-1)
        disp = float_array(displacements, "displacements", (len(idx), 3))
        bad = [int(i) for i in idx if i != -1 and int(i) not in self.grip]
        if bad:
            raise ValueError(f"particles {bad} have no grasp equality in the arm's model")
        cfg = self.config
        self._blowup = None if blowup_out is None else (blowup_out, str(blowup_label))
        self._blowups = []
        self.start(object_state)
        out = PandaExecution(np.empty(0))
        t_free = max(2, int(round(cfg.approach_time / self.dt)))
        up = np.array([0.0, 0.0, cfg.approach])
        self._hold(t_free)                                     # settle at the ready pose
        snap = (lambda: out.snapshots.append(self.state())) if snapshots else (lambda: None)
        snap()
        for k, (i, dv) in enumerate(zip(idx, disp, strict=True)):
            if i == -1:
                self._hold(int(self.scene.picker.moves(dv)) + self.settle_steps)
                continue
            # free moves to above the particle and down to it, each followed by as long a
            # hold; the targets follow the particle, which may still be moving (the cloth
            # relaxes after the previous release while the arm comes)
            for lift in (up, 0.0 * up):
                def above(i=i, lift=lift):
                    return self.particle(i) + lift
                self._move(above, t_free)
                self._move(above, t_free, hold=True)
            dist = float(np.linalg.norm(self.pinch() - self.particle(i)))
            out.grasp_distance.append(dist)
            if dist > cfg.grasp_tolerance:          # out of reach: the action is not executed
                log.warning("the pinch is %.1f mm from particle %d, beyond the grasp "
                            "tolerance: action %d skipped", dist * 1e3, i, k)
                out.missed.append(k)
                self._move(self._target_now() + up, t_free)
                continue
            self.data.ctrl[self.fingers] = 0.0
            self.data.eq_active[self.grip[int(i)]] = 1
            self._hold(cfg.grasp_steps)
            snap()
            start = self._target_now()
            out.carry_error.append(self._move(start + dv, int(self.scene.picker.moves(dv))))
            snap()
            self.data.eq_active[self.grip[int(i)]] = 0
            self.data.ctrl[self.fingers] = 0.04
            self._hold(cfg.grasp_steps)
            self._move(self._target_now() + up, t_free)
            self._hold(self.settle_steps)
            snap()
        out.positions = self.positions()
        out.steps = self._t
        warned = [mujoco.mjtWarning(w).name for w in range(len(self.data.warning))
                  if self.data.warning[w].number]
        if warned or not np.all(np.isfinite(self.data.qpos)):
            self._scan.flag(0, self._t, "MuJoCo warned: " + ", ".join(warned) if warned
                            else "non-finite state")
        out.stability, out.blowups, self._blowup = self._scan.result(), self._blowups, None
        if out.unstable:
            log.warning("the arm's replay went unstable: %s", out.stability.reason[0])
        return out

    def state(self) -> np.ndarray:
        """(ns,) the combined model's ``SNAPSHOT_SPEC`` state now (for pictures)."""
        out = np.empty(mujoco.mj_stateSize(self.model, SNAPSHOT_SPEC))
        mujoco.mj_getState(self.model, self.data, out, SNAPSHOT_SPEC)
        return out

    def positions(self) -> np.ndarray:
        """(N, 3) the object's particles now (m)."""
        return self._origin + self.data.qpos[self._vq]
