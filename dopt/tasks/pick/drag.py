"""Short drags of virtual pick points on a cloth mesh: the physics of the key-particle
authors' action encoding (SoftGym's ``Picker.step``), decoupled from the mesh's resolution.

A virtual point is a fixed place on the sheet, given in rest coordinates and attached to the
mesh barycentrically (``VirtualPoints``: its triangle and weights), so that any number of
candidate pick points, 10,000 among them, costs the simulation of the physics mesh alone.
The point moves with its triangle: at any state its position is the weighted sum of the
triangle's three vertices.

A drag sequence is T decisions. Decision t grasps point ``picks[t]`` (``NONE = -1``: holds
nothing) and moves it by ``moves[t]`` (3,) metres per substep for ``DragConfig.repeat``
substeps (the authors' ``action_repeat``), each substep ``DragConfig.substeps`` MuJoCo steps at
constant velocity. As in SoftGym the grasp is instant and re-made at every decision: the
picker is put at the point (no snap phase) and holds the point's triangle by three ``connect``
equalities anchored at the vertices' offsets from the point at that moment, so the triangle
travels rigidly with the picker for the decision (SoftGym gives the picked particle infinite
mass instead; a grasped triangle is the patch a pinch holds). After the last decision the
sheet is released and settles for ``DragConfig.settle`` seconds.

``DragSimulator.run`` steps MuJoCo from Python (each rollout's grasp anchors are its own, so
the rollouts cannot share one batched model), with the scene's stability verdict evaluated
on every step as in ``dopt.rollout`` (``dopt.stability.Monitor``).

Shapes: P rollouts, T decisions, V mesh vertices, E triangles, N virtual points, ns state row.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import mujoco
import numpy as np

from dopt.kernels import warning_names
from dopt.stability import Stability
from dopt.state import fault
from dopt.tasks.pick.picker import CONTROL_SPEC, NONE
from dopt.tasks.pick.scene import DeformableScene
from dopt.validation import check_config, float_array

#: how far outside every triangle (in barycentric weight) a point may lie and still be on
#: the mesh (rounding at shared edges)
ON_MESH = 1e-9


@dataclass(frozen=True)
class DragConfig:
    """A drag decision's timing (the authors' ``Picker.step`` under ``action_repeat``).

    Attributes:
        step: largest move per axis of one substep (m): SoftGym's 1 cm.
        repeat: substeps per decision (SoftGym's ``action_repeat``, 8 on the cloth folds).
        substeps: MuJoCo steps per substep (1: the authors' speed, 1 cm per step).
        settle: seconds the released sheet settles after the last decision.
    """

    step: float = 0.01
    repeat: int = 8
    substeps: int = 1
    settle: float = 0.25

    def __post_init__(self):
        check_config(self, positive=("step",), minimum={"repeat": 1, "substeps": 1,
                                                        "settle": 0})

    def steps(self, dt: float) -> tuple[int, int]:
        """(MuJoCo steps of one decision, of the final settle) at the timestep dt (s)."""
        return self.repeat * self.substeps, int(np.ceil(self.settle / dt))


class VirtualPoints:
    """Points attached to a triangle mesh by barycentric weights.

    Args:
        rest: (V, 3) the mesh's vertices at rest (a flat sheet: located in x, y).
        triangles: (E, 3) vertex indices of its triangles.
        points: (N, 3) the points at rest, each on the mesh.

    Attributes:
        triangles: (N, 3) the vertices of each point's triangle; weights: (N, 3) its
            barycentric weights (>= 0, summing to 1).

    Raises:
        ValueError: a point off the mesh (outside every triangle by more than ``ON_MESH``).
    """

    def __init__(self, rest, triangles, points):
        rest = float_array(rest, "rest")
        tri = np.asarray(triangles)
        if tri.dtype.kind not in "iu":
            raise TypeError(f"triangles must be integer vertex indices, got dtype {tri.dtype}")
        if tri.size and (tri.min() < 0 or tri.max() >= len(rest)):
            raise ValueError(f"triangles must index the {len(rest)} vertices")
        pts = float_array(points, "points")
        if rest.ndim != 2 or rest.shape[1] != 3 or tri.ndim != 2 or tri.shape[1] != 3 \
                or pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(f"rest (V, 3), triangles (E, 3) and points (N, 3) expected, got "
                             f"{rest.shape}, {tri.shape}, {pts.shape}")
        which, weights = _locate(rest[:, :2], tri, pts[:, :2])
        self.triangles = tri[which]
        self.weights = weights

    def __len__(self) -> int:
        return len(self.weights)

    def positions(self, vertices: np.ndarray) -> np.ndarray:
        """The points' positions on a mesh state: vertices (..., V, 3) -> (..., N, 3)."""
        v = np.asarray(vertices, dtype=float)
        return np.einsum("...nkd,nk->...nd", v[..., self.triangles, :], self.weights)


def _locate(rest2: np.ndarray, tri: np.ndarray, pts2: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """Each point's triangle (N,) and barycentric weights (N, 3) in the plane, the triangle
    whose smallest weight is largest; ValueError for a point outside every one."""
    a, b, c = rest2[tri[:, 0]], rest2[tri[:, 1]], rest2[tri[:, 2]]       # (E, 2)
    v0, v1 = b - a, c - a
    det = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]                      # (E,)
    which = np.empty(len(pts2), dtype=int)
    weights = np.empty((len(pts2), 3))
    for s in range(0, len(pts2), 512):
        d = pts2[s:s + 512, None, :] - a[None]                          # (n, E, 2)
        w1 = (d[..., 0] * v1[:, 1] - d[..., 1] * v1[:, 0]) / det
        w2 = (v0[:, 0] * d[..., 1] - v0[:, 1] * d[..., 0]) / det
        w = np.stack([1 - w1 - w2, w1, w2], axis=-1)                    # (n, E, 3)
        best = w.min(axis=-1).argmax(axis=-1)                            # (n,)
        chosen = w[np.arange(len(best)), best]
        off = chosen.min(axis=-1) < -ON_MESH
        if off.any():
            i = s + int(np.flatnonzero(off)[0])
            raise ValueError(f"points: point {i} at {pts2[i].tolist()} lies off the mesh")
        chosen = np.clip(chosen, 0.0, None)
        which[s:s + 512], weights[s:s + 512] = best, chosen / chosen.sum(-1, keepdims=True)
    return which, weights


@dataclass(frozen=True)
class DragResult:
    """Drag rollouts: the state at the end of each decision (P, T, ns) (the grasp still on),
    the final state after the release and settle (P, ns), and the stability verdict over
    every step (``step`` counts MuJoCo steps from the start)."""

    decision_states: np.ndarray
    final_states: np.ndarray
    stability: Stability


class DragSimulator:
    """Drag rollouts of a cloth scene (module docstring).

    Args:
        scene: a ``DeformableScene`` of a 2D flex whose picker can grasp every vertex.
        config: the drag timing.
    """

    def __init__(self, scene: DeformableScene, config: DragConfig = DragConfig()):
        if not isinstance(scene, DeformableScene):
            raise TypeError(f"scene must be a DeformableScene, got {type(scene).__name__}")
        if not isinstance(config, DragConfig):
            raise TypeError(f"config must be a DragConfig, got {type(config).__name__}")
        if scene.elements.shape[1] != 3:
            raise ValueError("scene: drags need a triangle mesh (a cloth), not a rope")
        if len(scene.picker.pickable) != scene.n_particles:
            raise ValueError("scene: its picker must be able to grasp every vertex")
        self.scene, self.config = scene, config
        self.model = copy.copy(scene.model)           # its grasp anchors change per decision
        m = self.model
        self._grasp = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, f"pick{i}")
                                for i in range(scene.n_particles)])
        joints = [m.joint(f"picker_{a}") for a in "xyz"]
        self._picker_qpos = np.array([int(j.qposadr[0]) for j in joints])
        self._picker_dof = np.array([int(j.dofadr[0]) for j in joints])
        self._picker_range = np.array([j.range if j.limited[0] else (-np.inf, np.inf)
                                       for j in joints], dtype=float)
        self._picker_joint = np.array([j.id for j in joints])
        self._picker_origin = np.asarray(scene.picker.config.start, dtype=float)
        self.decision_steps, self.settle_steps = config.steps(float(m.opt.timestep))

    def velocities(self, moves: np.ndarray) -> np.ndarray:
        """Picker velocities (m/s) of moves per substep (..., 3) m."""
        return np.asarray(moves, float) / (self.config.substeps * self.model.opt.timestep)

    def run(self, start_state, points: VirtualPoints, picks, moves) -> DragResult:
        """P drag sequences from ``start_state`` (ns,): ``picks`` (P, T) point indices into
        ``points`` (``NONE`` = -1: hold nothing), ``moves`` (P, T, 3) metres per substep,
        each within +-``DragConfig.step`` per axis.

        Raises:
            ValueError: shapes that do not match, a pick outside -1 .. N-1, a move beyond the
                step.
        """
        picks, moves = self._check(points, picks, moves)
        P, T = picks.shape
        scene = self.scene
        x0 = np.asarray(start_state, dtype=float)
        states = np.empty((P, T, scene.nstate))
        final = np.empty((P, scene.nstate))
        scan = scene.scene.monitor.start(P)
        data = mujoco.MjData(self.model)
        for p in range(P):
            mujoco.mj_setState(self.model, data, x0, scene.scene.layout.spec)
            step = 0
            for t in range(T):
                row = self._grasp_row(data, points, int(picks[p, t]), moves[p, t])
                step = self._advance(data, row, self.decision_steps, scan, p, step)
                states[p, t] = scene.scene.state_of(data)
            step = self._advance(data, scene.picker.idle_row, self.settle_steps, scan, p, step)
            final[p] = scene.scene.state_of(data)
        return DragResult(states, final, scan.result())

    def _check(self, points, picks, moves) -> tuple[np.ndarray, np.ndarray]:
        if not isinstance(points, VirtualPoints):
            raise TypeError(f"points must be VirtualPoints, got {type(points).__name__}")
        idx = np.asarray(picks)
        if idx.dtype.kind not in "iu":
            raise TypeError(f"picks must be integer point indices, got dtype {idx.dtype}")
        mv = float_array(moves, "moves")
        if idx.ndim != 2 or mv.shape != idx.shape + (3,) or not idx.size:
            raise ValueError(f"picks (P, T) and moves (P, T, 3) expected, got {idx.shape} and "
                             f"{mv.shape}")
        if ((idx < NONE) | (idx >= len(points))).any():
            raise ValueError(f"picks must lie in -1 .. {len(points) - 1}, got "
                             f"{idx.min()} .. {idx.max()}")
        if (np.abs(mv) > self.config.step * (1 + 1e-9)).any():
            raise ValueError(f"moves must lie within +-{self.config.step} m per axis, got "
                             f"{np.abs(mv).max():.4g}")
        return idx.astype(np.int64), mv

    def _grasp_row(self, data: mujoco.MjData, points: VirtualPoints, pick: int,
                   move: np.ndarray) -> np.ndarray:
        """Grasp point ``pick`` where it is now (picker put there, anchors at the triangle's
        offsets); the control row of the decision (``NONE``: the idle row, nothing held)."""
        picker = self.scene.picker
        if pick == NONE:
            self.model.jnt_range[self._picker_joint[2], 0] = self._picker_range[2, 0]
            return picker.idle_row
        tri = points.triangles[pick]
        x = self.scene.positions(self.scene.scene.state_of(data))[tri]      # (3, 3)
        at = points.weights[pick] @ x
        q = np.clip(at - self._picker_origin, self._picker_range[:, 0], self._picker_range[:, 1])
        data.qpos[self._picker_qpos] = q
        data.qvel[self._picker_dof] = 0.0
        held = self._picker_origin + q
        # the held patch stays above the floor: the picker stops where the lowest held
        # vertex would reach the picker's own floor limit (SoftGym clips the picked particle)
        zlow = self._picker_range[2, 0] - min(0.0, float((x[:, 2] - held[2]).min()))
        self.model.jnt_range[self._picker_joint[2], 0] = min(zlow, q[2])
        self.model.eq_data[self._grasp[tri], 0:3] = x - held
        self.model.eq_data[self._grasp[tri], 3:6] = 0.0
        mujoco.mj_forward(self.model, data)
        return picker.control_row(tri, self.velocities(move))

    def _advance(self, data: mujoco.MjData, row: np.ndarray, n: int, scan, p: int,
                 step: int) -> int:
        """n steps under the control row, folded into the verdict of rollout p; returns the
        step count after them (a rollout already unstable keeps stepping, unjudged)."""
        m, mon = self.model, self.scene.scene.monitor
        mujoco.mj_setState(m, data, row, CONTROL_SPEC)
        if n == 0:
            return step
        fields = {name: [] for name in mon.record}
        for _ in range(n):
            mujoco.mj_step(m, data)
            for name in fields:
                fields[name].append(np.array(getattr(data, name)))
        if not scan.unstable[p]:
            scan.update(np.array([p]), step, {k: np.stack(v)[None] for k, v in fields.items()})
            if names := warning_names(data.warning.number):
                scan.flag(p, step + n - 1, f"MuJoCo warning {names[0]}")
            elif (why := fault(self.scene.scene.layout, self.scene.scene.state_of(data))):
                scan.flag(p, step + n - 1, why)
        return step + n
