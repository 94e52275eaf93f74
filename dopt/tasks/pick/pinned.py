"""A rope or cloth scene with some particles held fixed in the world: the supports of the
physics references (a catenary's pins, a cantilever's clamp; ``planners.bench.reference``).

``PinnedScene(scene, pins)`` recompiles a ``DeformableScene``'s MJCF (the scene as the pick
tasks build it, picker included) with the slide joints of the pinned particles removed, so that
each is a body welded to the world, and then moves those bodies to the pins. Moving them after
compiling keeps MuJoCo's compile-time rest shape of the scene as built (the straight rope's
edge lengths and zero rest curvature, the flat sheet's reference metric): moved before, the
moved layout would become the rest shape.

``PinnedScene.relax`` lets the other particles come to static equilibrium under gravity and
optional point forces. For the relaxation only, it damps each free particle's slide joints by
``rate`` times its mass (mass-proportional damping: critical for a mode of angular frequency
rate / 2), which changes how fast the equilibrium is reached, not where it is.

Shapes: N particles, k pinned.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass

import mujoco
import numpy as np

from dopt.tasks.pick.scene import DeformableScene
from dopt.validation import check_real, float_array, index_array


@dataclass(frozen=True)
class Relaxed:
    """The end of ``PinnedScene.relax``.

    Attributes:
        positions: (N, 3) particle positions (m).
        speed: the largest free particle speed at the end (m/s): near zero at equilibrium.
        steps: simulation steps taken; wall_s, cpu_s: their wall and CPU time (s), one
            thread (the CPU time is what a busy machine does not inflate).
    """

    positions: np.ndarray
    speed: float
    steps: int
    wall_s: float
    cpu_s: float


class PinnedScene:
    """A deformable scene whose ``pinned`` particles are welded to the world at ``pins``.

    Attributes:
        model: the recompiled model (its own: ``relax`` changes its gravity and damping);
        flex: the flex's name; n_particles: N; pinned: (k,) the pinned particles, sorted;
        pins: (k, 3) where they are held (m), in the order of ``pinned``; free: (N - k,) the
        other particles; edges: (E, 2) the flex's edges in particle indices.
    """

    def __init__(self, scene: DeformableScene, pins: Mapping[int, object]):
        if not isinstance(scene, DeformableScene):
            raise TypeError(f"scene must be a DeformableScene, got {type(scene).__name__}")
        if scene.xml is None:
            raise ValueError("scene has no MJCF (DeformableScene.xml): build it with the "
                             "pick tasks' builders (dopt.tasks.PICK_SCENES)")
        if not isinstance(pins, Mapping):
            raise TypeError(f"pins must map particle -> position, got {type(pins).__name__}")
        n = scene.n_particles
        ids = index_array(list(pins), "pins (particles)", n)
        where = float_array([pins[i] for i in pins], "pins (positions)", (len(ids), 3))
        if len(ids) == n:
            raise ValueError("pins holds every particle: nothing is left to move")
        order = np.argsort(ids)
        self.flex, self.n_particles = scene.flex, n
        self.pinned, self.pins = ids[order], where[order]
        self.free = np.setdiff1d(np.arange(n), self.pinned)
        spec = mujoco.MjSpec.from_string(scene.xml)
        for i in self.pinned:
            for joint in list(spec.body(f"{self.flex}_{i}").joints):
                spec.delete(joint)
        self.model = spec.compile()
        m = self.model
        self._bodies = np.array([m.body(f"{self.flex}_{i}").id for i in range(n)])
        m.body_pos[self._bodies[self.pinned]] = self.pins
        f = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_FLEX, self.flex)
        self.edges = m.flex_edge[m.flex_edgeadr[f]:][:m.flex_edgenum[f]].astype(np.int64)
        joints = m.body_jntadr[self._bodies[self.free]]
        axes = m.jnt_axis[joints[:, None] + np.arange(3)]                       # (N - k, 3, 3)
        if not np.allclose(axes, np.eye(3)):
            raise ValueError("the free particles must move on world-axis slide joints x, y, z")
        self._qpos = m.jnt_qposadr[joints][:, None] + np.arange(3)             # (N - k, 3)
        self._dofs = m.jnt_dofadr[joints][:, None] + np.arange(3)
        data = mujoco.MjData(m)
        mujoco.mj_kinematics(m, data)
        self._origin = data.xpos[self._bodies[self.free]].copy()             # at qpos = 0

    def positions(self, data: mujoco.MjData) -> np.ndarray:
        """Particle positions of ``data`` (its qpos): (N, 3)."""
        out = np.empty((self.n_particles, 3))
        out[self.pinned] = self.pins
        out[self.free] = self._origin + data.qpos[self._qpos]
        return out

    def place(self, positions) -> mujoco.MjData:
        """Fresh data with the particles at ``positions`` (N, 3), at rest; the pinned rows must
        be the pins."""
        pos = float_array(positions, "positions", (self.n_particles, 3))
        off = np.abs(pos[self.pinned] - self.pins).max()
        if off > 1e-9:
            raise ValueError(f"positions puts a pinned particle {off:.3g} m off its pin")
        data = mujoco.MjData(self.model)
        data.qpos[self._qpos] = pos[self.free] - self._origin
        mujoco.mj_forward(self.model, data)
        return data

    def relax(self, start, seconds: float, rate: float, *,
              gravity=(0.0, 0.0, -9.81), forces: Mapping[int, object] | None = None) -> Relaxed:
        """From ``start`` (N, 3) at rest, ``seconds`` of simulation under ``gravity`` (3,) m/s^2
        and point ``forces`` (particle -> (3,) N, held constant), with the free particles'
        slide joints damped by ``rate`` (1/s) times their mass."""
        seconds = check_real(seconds, "seconds", positive=True)
        rate = check_real(rate, "rate", minimum=0)
        gravity = float_array(gravity, "gravity", (3,))
        m = self.model
        data = self.place(start)
        for i, force in (forces or {}).items():
            i = int(index_array(i, "forces (particle)", self.n_particles)[0])
            data.xfrc_applied[self._bodies[i], :3] = float_array(force, "forces", (3,))
        saved = m.dof_damping.copy(), m.opt.gravity.copy()
        mass = m.body_mass[self._bodies[self.free]]
        try:
            m.dof_damping[self._dofs] = rate * mass[:, None]
            m.opt.gravity[:] = gravity
            steps = int(np.ceil(seconds / m.opt.timestep))
            t0, c0 = time.perf_counter(), time.thread_time()
            for _ in range(steps):
                mujoco.mj_step(m, data)
            wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
        finally:
            m.dof_damping[:], m.opt.gravity[:] = saved
        speed = np.linalg.norm(data.qvel[self._dofs], axis=1).max()
        return Relaxed(self.positions(data), float(speed), steps, wall, cpu)

