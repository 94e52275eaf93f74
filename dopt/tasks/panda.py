"""The Franka Panda arm both task wings use: the shipped MuJoCo model, its DH table and limits, a
torch forward-kinematics chain of the end effector, a small inverse kinematics for start poses,
and the table top the arm is mounted on.

A neutral module of ``dopt.tasks``, imported by both wings and importing neither: the push tasks
(``dopt.tasks.push``) drive the arm with its pusher tool, the pick wing's executor
(``dopt.tasks.pick.panda_gripper``) replaces the tool by a two-finger hand.

The arm stands at the world origin with its base on the table plane z = 0, facing +x. The
MuJoCo model is ``assets/panda.xml`` (7 hinge joints driven by torque motors, gravity
compensated, a pusher tool on the flange whose tip is the site ``EE_SITE``); the URDF
``assets/panda.urdf`` is generated from the DH table below by ``panda_urdf`` (see
``assets/generate_panda_urdf.py``) and is what pytorch-kinematics loads.

Shape letters (see ``dopt``): B a batch of joint configurations, ns the size of one
``mjSTATE_INTEGRATION`` state.
"""

from __future__ import annotations

import functools
import logging
import math
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco
import numpy as np

# torch and pytorch-kinematics load in ee_chain, so importing the tasks stays light
if TYPE_CHECKING:
    import pytorch_kinematics as pk
    import torch

log = logging.getLogger(__name__)

ASSETS_DIR = Path(__file__).resolve().parent / "assets"
PANDA_XML = ASSETS_DIR / "panda.xml"
PANDA_URDF = ASSETS_DIR / "panda.urdf"

# Craig (modified) DH parameters of joints 1..7 and the flange offset, from Franka's "Robot and
# interface specifications".
# Frame i = frame i-1 * RotX(alpha_i) * TransX(a_i) * RotZ(q_i) * TransZ(d_i).
DH_A = (0.0, 0.0, 0.0, 0.0825, -0.0825, 0.0, 0.088)
DH_D = (0.333, 0.0, 0.316, 0.0, 0.384, 0.0, 0.0)
DH_ALPHA = (0.0, -math.pi / 2, math.pi / 2, math.pi / 2, -math.pi / 2, math.pi / 2, math.pi / 2)
FLANGE_D = 0.107
# The pusher tool (ours): a rod along the flange z axis; the end effector is its tip's centre.
TOOL_LENGTH = 0.13
TOOL_RADIUS = 0.015

# Datasheet joint position limits (rad), torque limits (N m) and velocity limits (rad/s).
Q_LOWER = np.array([-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973])
Q_UPPER = np.array([2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973])
TAU_MAX = np.array([87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0])
QD_MAX = np.array([2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61])

JOINT_NAMES = tuple(f"panda_joint{i}" for i in range(1, 8))
ACTUATOR_NAMES = tuple(f"panda_motor{i}" for i in range(1, 8))
BODY_NAMES = tuple(f"panda_link{i}" for i in range(8)) + ("panda_pusher",)
EE_SITE = "panda_ee"
EE_LINK = "panda_ee"  # the URDF link at the same place as EE_SITE
TABLE_NAME = "table"

# Seed of the IK for poses with the tool pointing down in front of the robot (elbow up).
_IK_SEED = np.array([0.0, 0.3, 0.0, -2.2, 0.0, 2.5, math.pi / 4])
_DOWN = np.array([0.0, 0.0, -1.0])


def panda_spec() -> mujoco.MjSpec:
    """A fresh, editable spec of the arm alone, parsed from ``assets/panda.xml``."""
    return mujoco.MjSpec.from_file(str(PANDA_XML))


@functools.lru_cache(maxsize=1)
def arm_model() -> mujoco.MjModel:
    """The compiled arm alone (nq = nv = nu = 7), shared: treat it as read-only."""
    return panda_spec().compile()


def table_scene_spec(timestep: float, integrator: mujoco.mjtIntegrator) -> mujoco.MjSpec:
    """The arm on a table top, ready for a task to add its objects.

    The table is the plane ``TABLE_NAME`` at z = 0 (friction 0.5); the arm's base stands on it at
    the origin. ``timestep`` (s) and ``integrator`` set the model options.
    """
    if timestep <= 0:
        raise ValueError(f"timestep must be positive, got {timestep}")
    spec = panda_spec()
    spec.option.timestep = timestep
    spec.option.integrator = integrator
    spec.worldbody.add_geom(
        name=TABLE_NAME,
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[2.0, 2.0, 0.05],
        friction=[0.5, 0.005, 0.0001],
        rgba=[0.8, 0.75, 0.65, 1.0],
    )
    spec.worldbody.add_light(pos=[0.5, 0.0, 2.0], dir=[0.0, 0.0, -1.0])
    return spec


def arm_qpos_index(model: mujoco.MjModel) -> np.ndarray:
    """(7,) indices into ``qpos`` of the arm's joints (in the order of ``JOINT_NAMES``) in any
    model that contains the arm."""
    return np.array([model.joint(name).qposadr[0] for name in JOINT_NAMES])


def ik_pointing_down(
    target: np.ndarray,
    *,
    tol: float = 1e-6,
    max_iters: int = 200,
    damping: float = 1e-2,
    limit_margin: float = 0.05,
) -> np.ndarray:
    """Joint angles that put the end effector at ``target`` with the tool pointing straight down.

    Damped least squares on MuJoCo's site Jacobian of the arm model, from an elbow-up seed turned
    toward the target; joints are kept ``limit_margin`` rad inside their limits. The rotation
    of the tool about its own (vertical) axis is left free.

    Args:
        target: (3,) world position of the end-effector site (m).
    Returns:
        (7,) joint angles (rad), ordered as ``JOINT_NAMES``.
    Raises:
        ValueError: ``target`` is not a finite 3-vector.
        RuntimeError: position or axis error still above ``tol`` after ``max_iters`` steps
            (the target is out of reach).
    """
    target = np.asarray(target, dtype=float)
    if target.shape != (3,) or not np.all(np.isfinite(target)):
        raise ValueError(f"target must be a finite (3,) position, got {target!r}")
    model = arm_model()
    data = mujoco.MjData(model)
    site = model.site(EE_SITE).id
    lower, upper = Q_LOWER + limit_margin, Q_UPPER - limit_margin
    q = _IK_SEED.copy()
    q[0] = math.atan2(target[1], target[0])
    jac_pos, jac_rot = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    for _ in range(max_iters):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        tool_axis = data.site_xmat[site].reshape(3, 3)[:, 2]
        error = np.concatenate([target - data.site_xpos[site], np.cross(tool_axis, _DOWN)])
        if np.linalg.norm(error[:3]) < tol and np.linalg.norm(error[3:]) < tol:
            return q
        mujoco.mj_jacSite(model, data, jac_pos, jac_rot, site)
        jac = np.vstack([jac_pos, jac_rot])
        step = jac.T @ np.linalg.solve(jac @ jac.T + damping**2 * np.eye(6), error)
        q = np.clip(q + step, lower, upper)
    raise RuntimeError(
        f"IK did not reach {target} with the tool down: position error "
        f"{np.linalg.norm(error[:3]):.2e} m, axis error {np.linalg.norm(error[3:]):.2e}"
    )


def rest_state(model: mujoco.MjModel, arm_qpos: np.ndarray, settle_steps: int) -> np.ndarray:
    """The initial state of a task: the arm at ``arm_qpos``, everything else settled.

    Sets the arm's joints (other joints keep ``qpos0``), then steps ``settle_steps`` times with
    zero controls so that objects come to rest on the table (gravity compensation holds the arm
    still), and resets the time to 0.

    Args:
        arm_qpos: (7,) joint angles, ordered as ``JOINT_NAMES``.
    Returns:
        (ns,) ``mjSTATE_INTEGRATION`` state, as ``mujoco.mj_getState`` writes it.
    Raises:
        RuntimeError: the settling raised a MuJoCo warning (an unstable model).
    """
    data = mujoco.MjData(model)
    data.qpos[arm_qpos_index(model)] = arm_qpos
    mujoco.mj_forward(model, data)
    for _ in range(settle_steps):
        mujoco.mj_step(model, data)
    warnings = {mujoco.mjtWarning(i).name: w.number for i, w in enumerate(data.warning) if w.number}
    if warnings:
        raise RuntimeError(f"MuJoCo warnings while the scene settled: {warnings}")
    data.time = 0.0
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    return state


def panda_urdf() -> str:
    """URDF text of the arm's kinematic chain, generated from the DH table.

    Links ``panda_link0..7`` (frames = the DH frames, as in ``panda.xml``), ``panda_pusher`` at
    the flange and ``EE_LINK`` at the tool tip; revolute joints ``JOINT_NAMES`` with datasheet
    limits. Kinematics only: masses and inertias live in ``panda.xml``.
    """
    lines = [
        '<?xml version="1.0"?>',
        "<!-- Generated by dopt.tasks.panda.panda_urdf from the Panda's Craig DH table. -->",
        '<robot name="panda">',
        '  <link name="panda_link0"/>',
    ]
    for i in range(7):
        a, d, alpha = DH_A[i], DH_D[i], DH_ALPHA[i]
        xyz = (a, -d * math.sin(alpha), d * math.cos(alpha))
        lines += [
            f'  <link name="panda_link{i + 1}"/>',
            f'  <joint name="{JOINT_NAMES[i]}" type="revolute">',
            f'    <parent link="panda_link{i}"/>',
            f'    <child link="panda_link{i + 1}"/>',
            f'    <origin xyz="{_fmt(xyz)}" rpy="{_fmt((alpha, 0.0, 0.0))}"/>',
            '    <axis xyz="0 0 1"/>',
            f'    <limit lower="{_fmt((Q_LOWER[i],))}" upper="{_fmt((Q_UPPER[i],))}"'
            f' effort="{_fmt((TAU_MAX[i],))}" velocity="{_fmt((QD_MAX[i],))}"/>',
            "  </joint>",
        ]
    for parent, child, offset in (("panda_link7", "panda_pusher", FLANGE_D),
                                  ("panda_pusher", EE_LINK, TOOL_LENGTH)):
        lines += [
            f'  <link name="{child}"/>',
            f'  <joint name="{child}_fixed" type="fixed">',
            f'    <parent link="{parent}"/>',
            f'    <child link="{child}"/>',
            f'    <origin xyz="0 0 {_fmt((offset,))}" rpy="0 0 0"/>',
            "  </joint>",
        ]
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def _fmt(values: tuple[float, ...]) -> str:
    """Space-separated numbers, rounded to 1e-12 (drops cos(pi/2) noise) and without "-0.0"."""
    return " ".join(repr(round(float(v), 12) + 0.0) for v in values)


def ee_chain(dtype: torch.dtype | None = None,
             device: str | torch.device = "cpu") -> pk.SerialChain:
    """pytorch-kinematics chain from ``panda_link0`` (the world frame) to ``EE_LINK``.

    ``chain.forward_kinematics(q)`` with q of shape (B, 7) (``JOINT_NAMES`` order) returns the
    end-effector transform; ``.get_matrix()`` is (B, 4, 4), its ``[:, :3, 3]`` agrees with
    MuJoCo's ``site_xpos`` of ``EE_SITE``. ``dtype`` defaults to ``torch.float64``.
    """
    import pytorch_kinematics as pk
    import torch

    chain = pk.build_serial_chain_from_urdf(PANDA_URDF.read_bytes(), EE_LINK)
    return chain.to(dtype=torch.float64 if dtype is None else dtype, device=device)
