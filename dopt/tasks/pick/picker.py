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

How long the move lasts is ``PickerConfig.move``: "fixed" (the default), every move as long
as the bound box's diagonal takes at ``speed``, so K is the same for every action; "sized",
each action's move as long as its own displacement takes at that speed, at least
``min_move`` seconds, so each action has its own K (at most the fixed one). A sequence is
then its actions' rows back to back; a batch of them is padded to the longest with idle rows
that are never simulated: ``Picker.schedule`` gives each sequence's own length, which
``RolloutService.rollout(..., lengths=...)`` stops it at, so a sample's trajectory does not
depend on the others in its batch.

Shapes: P population, H actions per sequence, K steps per action, T steps of a batch (the
longest sequence's), N particles.
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
#: the rules of an action's move length (``PickerConfig.move``)
MOVE_RULES = ("fixed", "sized")


@dataclass(frozen=True)
class PickerConfig:
    """Picker mechanics and action timing.

    Attributes:
        bound: largest displacement per axis (m), |dx| <= bound[0], ... (the paper's Delta x,y,z).
        speed: average picker speed (m/s) of the longest move (the diagonal of the bound box),
            and with sized moves of every move longer than ``min_move``; about 0.5 m/s keeps
            the cloth from being flung.
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
        move: how long a move lasts (``MOVE_RULES``): "fixed", as long as the bound box's
            diagonal at ``speed`` for every action; "sized", as long as the action's own
            displacement |d| at ``speed`` (the same average, so the same peak speed, pi / 2
            times it, as a fixed move of that length), at least ``min_move`` and at most the
            fixed length (``move_steps``).
        min_move: seconds of the shortest "sized" move (the None action's and a zero
            displacement's). The smooth profile's peak acceleration is pi^2 |d| / (2 T^2), so
            a sized move's is at most pi^2 speed / (2 min_move): 9.9 m/s^2, about g, at the
            defaults (0.5 m/s, 0.25 s), where the fixed move's longest reaches 2.4 m/s^2
            (0.52 m in 1.04 s). Unused by "fixed".
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
    move: str = "fixed"
    min_move: float = 0.25

    def __post_init__(self):
        check_config(self, positive=("bound", "speed", "settle", "kv", "mass", "snap",
                                     "min_move"),
                     minimum={"hold_steps": 0}, choices={"move": MOVE_RULES})
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

    def move_steps(self, dt: float, displacements) -> np.ndarray:
        """Move steps of actions of displacements (..., 3) m at the timestep ``dt`` (s):
        (...) ints. "fixed": the fixed move of ``steps`` for each; "sized": |d| / speed in
        whole steps (rounded up), at least ``min_move`` (and 2 steps), at most the fixed move.
        A None action's displacement is zero: it gets the shortest move."""
        d = np.asarray(displacements, dtype=float)
        longest = self.steps(dt)[2]
        if self.move == "fixed":
            return np.full(d.shape[:-1], longest, dtype=np.int64)
        shortest = min(longest, max(2, int(np.ceil(self.min_move / dt))))
        own = np.ceil(np.linalg.norm(d, axis=-1) / self.speed / dt)
        return np.clip(own, shortest, longest).astype(np.int64)


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
        steps_per_action: K, the steps of an action with the fixed move (the most any action
            takes; with ``PickerConfig.move`` "sized", ``schedule`` gives each its own).
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

    @property
    def idle_row(self) -> np.ndarray:
        """(ncontrol,) control row holding nothing, servo on with v = 0."""
        return self._base.copy()

    def control_row(self, grasped=(), velocity=(0.0, 0.0, 0.0)) -> np.ndarray:
        """(ncontrol,) control row: servo on with the velocity target (3,) m/s, the grasp
        equalities of the particles ``grasped`` (k,) on (a drag that holds several at once,
        ``dopt.tasks.pick.drag``). ValueError naming a particle without a grasp equality."""
        ids = np.asarray(grasped, dtype=int).reshape(-1)
        bad = (ids < 0) | (ids >= self.n_particles)
        if bad.any() or (self._column[ids] < 0).any():
            raise ValueError(f"grasped: particles {ids.tolist()} must all have a grasp equality")
        row = self._base.copy()
        row[self._vel] = float_array(velocity, "velocity", (3,))
        row[self._column[ids]] = 1.0
        return row

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

    def moves(self, displacements) -> np.ndarray:
        """Move steps of actions of displacements (..., 3) m: (...) ints
        (``PickerConfig.move_steps`` at this model's dt; ``move_steps`` each with the fixed
        move)."""
        return self.config.move_steps(self.dt, displacements)

    def schedule(self, particles, displacements) -> Schedule:
        """The control rows of a batch of action sequences, (P, H), (P, H, 3), and how many
        steps of them each sequence simulates (module docstring): a ``Schedule``.

        Each sequence's rows are its actions' back to back; a sequence shorter than the
        batch's longest is padded with idle rows (``idle_row``) that are not its own. The
        rows of a sequence do not depend on the others in the batch. Raises as ``check``.
        """
        idx, disp = self.check(particles, displacements)
        P, H = idx.shape
        ns, nh, nset = self.snap_steps, self.hold_steps, self.settle_steps
        move = self.moves(disp)                                           # (P, H)
        steps = ns + nh + move + nset
        start = np.cumsum(steps, axis=1) - steps                          # (P, H)
        lengths = steps.sum(axis=1)
        U = np.empty((P, int(lengths.max()), self.ncontrol))
        U[:] = self._base
        for n in np.unique(move):
            profile = np.diff(smooth_profile(int(n))) / self.dt          # (n,), sum * dt == 1
            p, h = np.nonzero(move == n)
            t0 = start[p, h][:, None]                                     # (a, 1)
            held = idx[p, h] != NONE
            grasped = t0[held] + np.arange(ns + nh + n)                   # equality on
            U[p[held][:, None], grasped, self._column[idx[p, h][held]][:, None]] = 1.0
            snap = (t0[held] + np.arange(ns))[:, :, None]                 # servo off: snap
            U[p[held][:, None, None], snap, self._damp] = 0.0
            moving = (t0 + ns + nh + np.arange(n))[:, :, None]            # (a, n, 1)
            U[p[:, None, None], moving, self._vel] = \
                disp[p, h][:, None, :] * profile[None, :, None]
        return Schedule(U, lengths, steps)

    def encode(self, particles, displacements) -> np.ndarray:
        """Control rows of a batch of action sequences: (P, H), (P, H, 3) -> (P, T, ncontrol),
        T = H*K with the fixed move; with sized moves the longest sequence's steps, the others
        padded (``schedule``: simulate each only for its own ``lengths``).

        The rows are for ``RolloutService.rollout(..., control_spec=CONTROL_SPEC)``.
        """
        return self.schedule(particles, displacements).controls

    def decode(self, controls, horizon: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Inverse of :meth:`encode`: (P, T, ncontrol) -> particles (P, H), displacements
        (P, H, 3). With sized moves the actions' lengths are read from the rows and the
        horizon H must be given (the padding of a short sequence is idle rows, as a None
        action is); with fixed moves H = T / K when not given."""
        U = float_array(controls, "controls", finite=False)
        K = self.steps_per_action
        if U.ndim != 3 or U.shape[2] != self.ncontrol or not U.shape[1]:
            raise ValueError(f"controls must have shape (P, T, {self.ncontrol}), got {U.shape}")
        if horizon is None:
            if self.config.move != "fixed" or U.shape[1] % K:
                raise ValueError(f"controls of shape {U.shape} need the horizon: with sized "
                                 f"moves always, with fixed moves T must be H*{K}")
            horizon = U.shape[1] // K
        H = check_int(horizon, "horizon", minimum=1)
        idx = np.full((len(U), H), NONE, dtype=np.int64)
        disp = np.zeros((len(U), H, 3))
        ns, nh = self.snap_steps, self.hold_steps
        for p in range(len(U)):
            t = 0
            for h in range(H):
                grasp = U[p, t, self._grasp_cols] > 0.5
                n = self.moves(np.zeros(3))
                if grasp.any():
                    idx[p, h] = self.pickable[np.argmax(grasp)]
                    on = U[p, t:, self._column[idx[p, h]]] > 0.5
                    n = (np.argmin(on) if not on.all() else len(on)) - ns - nh
                k = ns + nh + int(n) + self.settle_steps
                if t + k > U.shape[1]:
                    raise ValueError(f"controls of sequence {p} end inside action {h} of "
                                     f"{H}: not {H} encoded actions")
                disp[p, h] = U[p, t:t + k][:, self._vel].sum(axis=0) * self.dt
                t += k
        return idx, disp


@dataclass(frozen=True)
class Schedule:
    """A batch of action sequences as control rows (``Picker.schedule``).

    Attributes:
        controls: (P, T, ncontrol) rows of ``CONTROL_SPEC``, T the longest sequence's steps.
        lengths: (P,) steps of each sequence (its rows after that are padding).
        steps: (P, H) steps of each action (K each with the fixed move).
    """

    controls: np.ndarray
    lengths: np.ndarray
    steps: np.ndarray
