"""A one-picker gripper for ropes and cloth whose pick-and-place actions are open-loop controls.

The picker is a light body on three world-axis slide joints. Each axis has a switchable damper
(``ctrl`` in [0, 1]) and a motor; with the damper on, the pair is a velocity servo
(force = kv * (v_target - v)), with it off the picker is free. Every pickable particle i has an
inactive ``connect`` equality ``pick<i>`` between the picker and its vertex body. All inputs are
part of ``CONTROL_SPEC = mjSTATE_CTRL | mjSTATE_EQ_ACTIVE``, so a whole population of action
sequences is one batched rollout and needs no particle position during the rollout.

One action ``(i, dx, dy, dz)`` is K = nsnap + nhold + nmove + nsettle steps:

1. snap (nsnap): equality ``pick<i>`` on, servo off; the picker is pulled onto particle i;
2. hold (nhold): servo on with v = 0 (kills the picker's residual velocity);
3. move (nmove): v(t) = d * s'(t) with a smooth 0 -> 1 profile s, so sum(v dt) = d;
4. settle (nsettle): equality off, servo on with v = 0; the object comes to rest.

The ``None`` action holds nothing for K steps. Particle index ``NONE = -1`` encodes it.
Shapes: P population, H actions per sequence, K steps per action, N particles.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import mujoco
import numpy as np

from dopt.state import StateLayout, check_model
from dopt.tasks.pick.constraints import ActionConstraint
from dopt.validation import as_array, check_config, check_int, float_array

#: particle index of the None action (hold nothing)
NONE = -1
#: what the picker's control rows set before every step: ctrl, then eq_active
CONTROL_SPEC = int(mujoco.mjtState.mjSTATE_CTRL) | int(mujoco.mjtState.mjSTATE_EQ_ACTIVE)
_AXES = "xyz"
#: most simulation steps one action may take (``PickerConfig.steps``): 500 s at dt 5 ms; a
#: slower picker or a longer bound is refused before any array of them is allocated
MAX_STEPS_PER_ACTION = 100_000


@dataclass(frozen=True)
class PickerConfig:
    """Picker mechanics and action timing.

    Attributes:
        bound: largest displacement per axis (m), |dx| <= bound[0], ... (the paper's Delta x,y,z).
        speed: average picker speed (m/s) of the longest move (the diagonal of the bound box);
            about 0.5 m/s keeps the cloth from being flung.
        settle: seconds of settling after each release.
        snap: seconds for the picker to snap onto the particle, rounded to whole steps of the
            scene's dt (0.06 s: 3 steps at dt 0.02, 12 at 5 ms). A fixed step count is not
            enough: the equality's time constant is at least 2 dt, and 3 steps at 5 ms leave
            the picker short of the particle, which the hold then lifts by about 2 cm.
        hold_steps: steps of holding still before the move.
        kv: servo gain (N s/m); 1000 tracks the commanded path within a millimetre.
        mass: picker mass (kg); tiny, so that snapping does not drag the particle.
        solref: solref of the grasp equalities.
        start: initial picker position (m), above the object.
        workspace: the action constraint whose box limits the picker's slide joints (every
            step of every rollout keeps the grasped particle inside it, as SoftGym clips its
            pickers; ``dopt.tasks.pick.constraints``); None: no box, only the floor stop.
    """

    bound: tuple[float, float, float] = (0.1, 0.1, 0.1)
    speed: float = 0.5
    settle: float = 0.25
    snap: float = 0.06
    hold_steps: int = 1
    kv: float = 1000.0
    mass: float = 1e-6
    solref: tuple[float, float] = (0.002, 1.0)
    start: tuple[float, float, float] = (0.0, 0.0, 0.3)
    workspace: ActionConstraint | None = None

    def __post_init__(self):
        check_config(self, positive=("bound", "speed", "settle", "kv", "mass", "snap"),
                     minimum={"hold_steps": 0})
        if self.workspace is not None:
            if not isinstance(self.workspace, ActionConstraint):
                raise TypeError(f"PickerConfig.workspace must be an ActionConstraint or None, "
                                f"got {type(self.workspace).__name__}")
            if not self.workspace.contains(self.start):
                raise ValueError(f"PickerConfig.start {tuple(self.start)} lies outside the "
                                 f"workspace box {self.workspace.low} .. {self.workspace.high}")
            extent = np.subtract(self.workspace.high, self.workspace.low)
            over = np.flatnonzero(np.asarray(self.bound) > extent)
            if len(over):
                a = int(over[0])
                raise ValueError(f"PickerConfig.bound {self.bound[a]:g} m is beyond the "
                                 f"workspace: the picker cannot move farther than "
                                 f"{extent[a]:g} m along {_AXES[a]} (the box "
                                 f"{self.workspace.low} .. {self.workspace.high})")

    def steps(self, dt: float) -> tuple[int, int, int, int]:
        """(snap, hold, move, settle) steps of one action at the timestep ``dt`` (s): the
        move covers the bound box's diagonal at ``speed``.

        Raises:
            ValueError: more than ``MAX_STEPS_PER_ACTION`` steps in all (a bound too long or a
                speed too slow for ``dt``), before anything is allocated.
        """
        move_s = float(np.linalg.norm(self.bound)) / self.speed
        total = (move_s + self.snap + self.settle) / dt + self.hold_steps
        if not total <= MAX_STEPS_PER_ACTION:
            raise ValueError(f"PickerConfig: one action would take {total:.3g} steps of "
                             f"{dt:g} s ({move_s:.3g} s to move the bound box's diagonal, "
                             f"{float(np.linalg.norm(self.bound)):.3g} m, at speed "
                             f"{self.speed:g} m/s), more than {MAX_STEPS_PER_ACTION}; raise "
                             f"the speed or lower the bound")
        return (max(1, int(round(self.snap / dt))), self.hold_steps,
                max(2, int(np.ceil(move_s / dt))), int(np.ceil(self.settle / dt)))


def picker_mjcf(flex_name: str, particles: Iterable[int],
                config: PickerConfig = PickerConfig(),
                lowest: float | None = None) -> tuple[str, str, str]:
    """MJCF fragments of the picker for the flex ``flex_name`` (vertex bodies
    ``<flex_name>_<i>``): (worldbody body, equality block content, actuator block content).

    ``particles``: the pickable particles, one ``connect`` equality each (only candidates need
    one). ``lowest``: the lowest height (m) the picker may reach (a joint limit; None: no
    limit). At the floor plus a particle radius, a move that points into the floor stops
    there instead of pressing the held particle through it (a grasp equality overpowers the
    floor contact: measured 22 mm deep, with 50 % edge strain, from random 12 x 12 cloth
    actions), as SoftGym's pickers are clipped above the floor. The compiled model must go
    through :func:`fix_grasp_anchors`.
    """
    start = np.asarray(config.start, dtype=float)
    lo, hi = np.full(3, -np.inf), np.full(3, np.inf)
    if config.workspace is not None:
        lo, hi = np.array(config.workspace.low), np.array(config.workspace.high)
    if lowest is not None:
        lo[2] = max(lo[2], float(lowest))
        hi[2] = (max(hi[2], lo[2] + 1e-3) if np.isfinite(hi[2])
                 else start[2] + max(1.0, 10 * start[2]))
    limit = ["" if not (np.isfinite(lo[a]) or np.isfinite(hi[a])) else
             f' limited="true" range="{lo[a] - start[a]:.6g} {hi[a] - start[a]:.6g}"'
             for a in range(3)]
    x, y, z = start
    body = (f'<body name="picker" pos="{x} {y} {z}" gravcomp="1">'
            + "".join(f'<joint name="picker_{a}" type="slide" axis="{axis}"{lim}/>'
                      for a, axis, lim in zip(_AXES, ("1 0 0", "0 1 0", "0 0 1"), limit,
                                              strict=True))
            + f'<geom name="picker" type="sphere" size="0.006" mass="{config.mass}" '
              f'contype="0" conaffinity="0" rgba="0.1 0.8 0.1 1"/></body>')
    ref = f"{config.solref[0]} {config.solref[1]}"
    eqs = "".join(f'<connect name="pick{i}" body1="picker" body2="{flex_name}_{i}" '
                  f'anchor="0 0 0" active="false" solref="{ref}"/>' for i in particles)
    acts = ("".join(f'<damper name="picker_damp_{a}" joint="picker_{a}" kv="{config.kv}" '
                    f'ctrlrange="0 1"/>' for a in _AXES)
            + "".join(f'<motor name="picker_vel_{a}" joint="picker_{a}" gear="{config.kv}" '
                      f'ctrllimited="false"/>' for a in _AXES))
    return body, eqs, acts


def grasp_equalities(model: mujoco.MjModel, prefix: str = "pick") -> dict[int, int]:
    """particle -> equality id of every ``<prefix><i>`` connect in ``model`` (the picker's
    ``pick<i>``; another gripper's grasps by their own prefix)."""
    out = {}
    for e in range(model.neq):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_EQUALITY, e) or ""
        if name.startswith(prefix) and name[len(prefix):].isdigit():
            out[int(name[len(prefix):])] = e
    return out


def fix_grasp_anchors(model: mujoco.MjModel, prefix: str = "pick") -> None:
    """Make every grasp equality (``<prefix><i>``) pull the gripper onto the vertex itself.

    For a body-to-body connect the compiler stores the qpos0 offset between the two bodies as
    body2's anchor; zero it (do not call ``mj_setConst`` afterwards, it recomputes it).
    """
    for e in grasp_equalities(model, prefix).values():
        model.eq_data[e, 3:6] = 0.0


def smooth_profile(n: int) -> np.ndarray:
    """(n + 1,) the smooth 0 -> 1 progress s(k / n) = (1 - cos(pi k / n)) / 2, k = 0..n, of a
    move in n steps (zero velocity at both ends)."""
    return 0.5 - 0.5 * np.cos(np.pi * np.arange(n + 1) / n)


class Picker:
    """Encodes pick-and-place action sequences into open-loop control rows and back.

    Args:
        model: the compiled model with the picker (after :func:`fix_grasp_anchors`).
        n_particles: N, particles of the object (valid indices 0..N-1).
        config: the picker config the model was built with.

    Attributes:
        steps_per_action: K.
        ncontrol: length of one control row (nu + neq).
        bound: (3,) displacement bound per axis.
        pickable: sorted particles that have a grasp equality.
    """

    def __init__(self, model: mujoco.MjModel, n_particles: int,
                 config: PickerConfig = PickerConfig()):
        check_model(model)
        if not isinstance(config, PickerConfig):
            raise TypeError(f"config must be a PickerConfig, got {type(config).__name__}")
        self.config = config
        self.n_particles = check_int(n_particles, "n_particles", minimum=1)
        self.dt = float(model.opt.timestep)
        self.bound = np.asarray(config.bound, dtype=float)
        layout = StateLayout.of(model, CONTROL_SPEC)
        self.ncontrol = layout.size
        ctrl, eq = layout["ctrl"], layout["eq_active"]
        act = {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a): a
               for a in range(model.nu)}
        try:
            self._damp = np.array([ctrl.start + act[f"picker_damp_{a}"] for a in _AXES])
            self._vel = np.array([ctrl.start + act[f"picker_vel_{a}"] for a in _AXES])
        except KeyError as e:
            raise ValueError(f"model has no picker actuator {e}; build it with picker_mjcf") \
                from None
        grasp = grasp_equalities(model)
        if not grasp:
            raise ValueError("model has no grasp equality pick<i>; build it with picker_mjcf")
        self.pickable = np.array(sorted(grasp), dtype=int)
        if self.pickable[-1] >= self.n_particles:
            raise ValueError(f"grasp equality pick{self.pickable[-1]} names a particle beyond "
                             f"N = {self.n_particles}")
        # control column of each particle's grasp equality, -1 where it has none; the extra
        # last entry (-1) is what the None action's index -1 looks up
        self._column = np.full(self.n_particles + 1, -1, dtype=int)
        for i, e in grasp.items():
            self._column[i] = eq.start + e
        self._grasp_cols = self._column[self.pickable]
        self._base = np.zeros(self.ncontrol)
        self._base[self._damp] = 1.0                                     # servo on
        others = np.setdiff1d(np.arange(model.neq), list(grasp.values()))
        self._base[eq.start + others] = model.eq_active0[others]         # e.g. rope edges
        self.snap_steps, self.hold_steps, self.move_steps, self.settle_steps = \
            config.steps(self.dt)
        self.steps_per_action = (self.snap_steps + self.hold_steps + self.move_steps
                                 + self.settle_steps)
        s = smooth_profile(self.move_steps)
        self._profile = np.diff(s) / self.dt                             # sum * dt == 1

    @property
    def idle_row(self) -> np.ndarray:
        """(ncontrol,) control row holding nothing, servo on with v = 0."""
        return self._base.copy()

    # ---------------------------------------------------------------- actions
    def check(self, particles, displacements) -> tuple[np.ndarray, np.ndarray]:
        """Validate a batch of action sequences.

        Args:
            particles: (P, H) or (H,) ints, particle index or NONE (-1).
            displacements: (P, H, 3) or (H, 3) metres.

        Returns:
            (P, H) int64 particles and (P, H, 3) float64 displacements (None actions' zeroed).

        Raises:
            TypeError: particles that are not integers (bool, str; floats must hold integer
                values), displacements that are not numbers.
            ValueError: shape mismatch, no action, a particle index out of range or without a
                grasp equality, a NaN/inf displacement, or one beyond the bound.
        """
        idx = as_array(particles, "particles")
        if idx.dtype.kind not in "iuf":
            raise TypeError(f"particles must be integer indices, got dtype {idx.dtype}")
        disp = float_array(displacements, "displacements", finite=False)
        if idx.ndim == 1:
            idx = idx[None]
        if disp.ndim == 2:
            disp = disp[None]
        if idx.ndim != 2 or disp.shape != idx.shape + (3,):
            raise ValueError(f"particles (P, H) and displacements (P, H, 3) do not match: "
                             f"{np.shape(particles)} and {np.shape(displacements)}")
        if not idx.size:
            raise ValueError(f"particles (P, H) must hold at least one sequence of at least one "
                             f"action, got shape {np.shape(particles)}")
        if idx.dtype.kind == "f":
            if not np.all(np.isfinite(idx)) or np.any(idx != np.round(idx)):
                raise ValueError(f"particle indices must be integers, got {idx.ravel()[:5]}")
        idx = idx.astype(np.int64)
        bad = (idx < NONE) | (idx >= self.n_particles)
        if bad.any():
            p, h = np.argwhere(bad)[0]
            raise ValueError(f"particle index {idx[p, h]} (sequence {p}, action {h}) is out of "
                             f"range: valid are 0..{self.n_particles - 1} or {NONE} for None")
        unpickable = (idx != NONE) & (self._column[idx] < 0)
        if unpickable.any():
            p, h = np.argwhere(unpickable)[0]
            raise ValueError(f"particle {idx[p, h]} (sequence {p}, action {h}) has no grasp "
                             f"equality; this model can pick {len(self.pickable)} particles "
                             f"({self.pickable[:8].tolist()}...)")
        finite = np.isfinite(disp).all(axis=-1)
        if not finite.all():
            p, h = np.argwhere(~finite)[0]
            raise ValueError(f"displacement of sequence {p}, action {h} is not finite: "
                             f"{disp[p, h].tolist()}")
        over = np.abs(disp) > self.bound * (1 + 1e-9)
        over &= (idx != NONE)[..., None]
        if over.any():
            p, h, a = np.argwhere(over)[0]
            raise ValueError(f"displacement {_AXES[a]} = {disp[p, h, a]:.4g} m of sequence {p}, "
                             f"action {h} is beyond the bound {self.bound[a]:.4g} m")
        disp = np.where((idx == NONE)[..., None], 0.0, disp)
        return idx, disp

    def encode(self, particles, displacements) -> np.ndarray:
        """Control rows of a batch of action sequences: (P, H), (P, H, 3) -> (P, H*K, ncontrol).

        The rows are for ``RolloutService.rollout(..., control_spec=CONTROL_SPEC)``.
        """
        idx, disp = self.check(particles, displacements)
        P, H = idx.shape
        K, ns = self.steps_per_action, self.snap_steps
        grasped = ns + self.hold_steps + self.move_steps   # steps with the equality on
        U = np.empty((P, H, K, self.ncontrol))
        U[:] = self._base
        p, h = np.nonzero(idx != NONE)
        cols = self._column[idx[p, h]]
        U[p[:, None], h[:, None], np.arange(grasped)[None, :], cols[:, None]] = 1.0
        U[p[:, None, None], h[:, None, None], np.arange(ns)[None, :, None],
          self._damp[None, None, :]] = 0.0                                 # servo off: snap
        moving = U[:, :, ns + self.hold_steps:grasped]                     # a view
        moving[..., self._vel] = disp[:, :, None, :] * self._profile[:, None]
        return U.reshape(P, H * K, self.ncontrol)

    def decode(self, controls) -> tuple[np.ndarray, np.ndarray]:
        """Inverse of :meth:`encode`: (P, H*K, ncontrol) -> particles (P, H), displacements
        (P, H, 3)."""
        U = float_array(controls, "controls", finite=False)
        K = self.steps_per_action
        if U.ndim != 3 or U.shape[2] != self.ncontrol or U.shape[1] % K:
            raise ValueError(f"controls must have shape (P, H*{K}, {self.ncontrol}), "
                             f"got {U.shape}")
        U = U.reshape(U.shape[0], -1, K, self.ncontrol)
        grasp = U[:, :, 0, self._grasp_cols] > 0.5                        # (P, H, npick)
        idx = np.where(grasp.any(-1), self.pickable[np.argmax(grasp, axis=-1)], NONE)
        disp = U[:, :, :, self._vel].sum(axis=2) * self.dt
        return idx.astype(np.int64), disp
